// Scan matching in a synthetic room: a submap built from scans at known poses, then a scan from a
// known pose matched from a wrong initial guess must come back to that pose.

#include <gtest/gtest.h>

#include <optional>
#include <tuple>

#include <Eigen/LU>

#include "rrr_graphslam/frontend/icp_refinement.h"
#include "rrr_graphslam/frontend/local_slam.h"
#include "rrr_graphslam/frontend/loop_search.h"
#include "rrr_graphslam/frontend/scan_matcher.h"
#include "rrr_graphslam/frontend/submap.h"
#include "rrr_graphslam/frontend/trajectory_refinement.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

using testing::castScan;
using testing::room;

Submap buildSubmap(const SubmapParams& params, const RangeScanParams& scan_params) {
  Submap submap(0, 0, core::Pose2(3.0, 2.0, 0.0), params);
  int node = 0;
  for (const core::Pose2& p :
       {core::Pose2(3.0, 2.0, 0.0), core::Pose2(6.0, 2.5, 0.5), core::Pose2(9.0, 3.0, 1.0),
        core::Pose2(6.0, 6.0, -2.0), core::Pose2(2.0, 4.0, 2.5)}) {
    // Each view a few times, as a real submap sees a place from many scans.
    for (int k = 0; k < 4; ++k)
      submap.insert(toObservation(castScan(room(), p), scan_params), p, node++);
  }
  return submap;
}

TEST(ScanMatcher, LocalMatchRecoversAKnownOffset) {
  const RangeScanParams scan_params;
  const Submap submap = buildSubmap(SubmapParams{}, scan_params);
  const core::Pose2 truth(5.0, 4.0, 0.3);
  const PointCloud points = matchingPoints(castScan(room(), truth), scan_params);
  const core::Pose2 prediction = truth + core::Pose2(0.08, -0.06, 0.05);
  const core::Pose2 coarse =
      realTimeCorrelativeMatch(submap.matchGrid(), prediction, points, CorrelativeParams{}).pose;
  EXPECT_LT((coarse.head<2>() - truth.head<2>()).norm(), 0.06) << coarse.transpose();
  LeastSquaresParams ls;
  ls.translation_weight = 0.1;  // a weak prior: the scan decides
  ls.rotation_weight = 0.1;
  const RefinedMatch refined = refineLeastSquares(submap.matchGrid(), coarse, coarse, points, ls);
  EXPECT_LT((refined.pose.head<2>() - truth.head<2>()).norm(), 0.02) << refined.pose.transpose();
  EXPECT_NEAR(core::normalizeAngle(refined.pose.z() - truth.z()), 0.0, 0.005);
  EXPECT_GT(refined.mean_probability, 0.6);
  EXPECT_TRUE(refined.information.allFinite());
  EXPECT_GT(refined.information.determinant(), 0.0);
}

TEST(ScanMatcher, IcpRefinementRecoversAKnownOffset) {
  const RangeScanParams scan_params;
  const Submap submap = buildSubmap(SubmapParams{}, scan_params);
  ASSERT_NE(submap.grid(), nullptr);
  const core::Pose2 truth(5.0, 4.0, 0.3);
  const PointCloud points = matchingPoints(castScan(room(), truth), scan_params);
  const core::Pose2 initial = truth + core::Pose2(0.08, -0.06, 0.03);
  const auto icp = refineIcp(*submap.grid(), initial, points, IcpRefinementParams{});
  ASSERT_TRUE(icp.has_value());
  // Point-to-point ICP against cell centres: within a cell (5 cm) of the truth, from 10 cm off.
  EXPECT_LT((icp->head<2>() - truth.head<2>()).norm(), 0.035) << icp->transpose();
  EXPECT_NEAR(core::normalizeAngle(icp->z() - truth.z()), 0.0, 0.005);
  // Nothing to align with: no pose.
  EXPECT_FALSE(
      refineIcp(*submap.grid(), truth + core::Pose2(40.0, 40.0, 0.0), points, IcpRefinementParams{})
          .has_value());
}

TEST(ScanMatcher, LoopSearchFindsTheScanMetresAway) {
  const RangeScanParams scan_params;
  Submap submap = buildSubmap(SubmapParams{}, scan_params);
  submap.finish();
  ASSERT_NE(submap.matcher(), nullptr);
  const core::Pose2 truth(8.0, 2.0, -0.4);
  const PointCloud points = matchingPoints(castScan(room(), truth), scan_params);
  LoopSearchParams params;
  const core::Pose2 guess = truth + core::Pose2(-2.5, 1.5, 0.3);
  const auto loop =
      matchNodeToSubmap(submap, 7, loopSearchScan(points, params), guess, params).loop;
  ASSERT_TRUE(loop.has_value());
  // From the submap's node nearest to the match, (9, 3) (nodes 8-11 were inserted there; the
  // first of them), not from the anchor 5 m away: local SLAM's drift inside the submap between
  // the anchor and there stays out of the constraint.
  ASSERT_EQ(submap.members().size(), 20U);
  EXPECT_EQ(submap.members().front().node, submap.anchorNode());
  EXPECT_EQ(loop->from, 8);
  EXPECT_EQ(loop->to, 7);
  const core::Pose2& from_pose = submap.members()[8].local_pose;
  EXPECT_EQ(from_pose, core::Pose2(9.0, 3.0, 1.0));
  const core::Pose2 found = core::compose(from_pose, loop->measurement);
  EXPECT_LT((found.head<2>() - truth.head<2>()).norm(), 0.03) << found.transpose();
  EXPECT_NEAR(core::normalizeAngle(found.z() - truth.z()), 0.0, 0.01);
  EXPECT_GT(loop->score, params.min_score);

  // On a real map the bounds prune: far fewer poses scored than the window holds.
  const SearchWindow small{2.0, 0.35};
  const core::Pose2 near_guess = truth + core::Pose2(-1.0, 0.8, 0.2);
  long long fast_scored = 0;
  long long slow_scored = 0;
  const auto fast = submap.matcher()->match(near_guess, points, small, params.min_score,
                                            std::nullopt, &fast_scored);
  const auto slow = submap.matcher()->matchExhaustive(near_guess, points, small, params.min_score,
                                                      std::nullopt, &slow_scored);
  ASSERT_TRUE(fast && slow);
  EXPECT_DOUBLE_EQ(fast->score, slow->score);
  EXPECT_LT((fast->pose - slow->pose).norm(), 1e-9);
  EXPECT_GT(fast_scored, 0);
  EXPECT_LT(fast_scored * 20, slow_scored);

  // Relocalization: no guess at all.
  const auto relocalized =
      matchNodeToWholeSubmap(submap, 7, loopSearchScan(points, params), params).loop;
  ASSERT_TRUE(relocalized.has_value());
  EXPECT_EQ(relocalized->from, 8);
  const core::Pose2 again = core::compose(from_pose, relocalized->measurement);
  EXPECT_LT((again.head<2>() - truth.head<2>()).norm(), 0.03) << again.transpose();
}

// Two copies of the room side by side, 14 m apart: a scan of one fits the other as well.
TEST(ScanMatcher, AMatchThatFitsTheRoomNextDoorAsWellIsAmbiguous) {
  const RangeScanParams scan_params;
  std::vector<testing::Segment> rooms = room();
  const Eigen::Vector2d next_door(14.0, 0.0);
  for (const testing::Segment& s : room()) rooms.push_back({s.a + next_door, s.b + next_door});
  Submap submap(0, 0, core::Pose2(3.0, 2.0, 0.0), SubmapParams{});
  int node = 0;
  for (const core::Pose2& p : {core::Pose2(3.0, 2.0, 0.0), core::Pose2(6.0, 2.5, 0.5),
                               core::Pose2(9.0, 3.0, 1.0), core::Pose2(6.0, 6.0, -2.0)}) {
    for (const core::Pose2& q : {p, core::Pose2(p.x() + next_door.x(), p.y(), p.z())}) {
      for (int k = 0; k < 4; ++k) {
        submap.insert(toObservation(castScan(rooms, q), scan_params), q, node++);
      }
    }
  }
  submap.finish();
  const core::Pose2 truth(5.0, 4.0, 0.3);
  const LoopSearchParams off;
  const LoopSearchScan scan =
      loopSearchScan(matchingPoints(castScan(rooms, truth), scan_params), off);
  // Between the rooms, a window reaching both.
  const core::Pose2 between(truth.x() + 7.0, truth.y(), truth.z());
  LoopSearchParams wide = off;
  wide.window.linear_m = 9.0;
  const SubmapSearch found = matchNodeToSubmap(submap, 99, scan, between, wide);
  ASSERT_TRUE(found.loop.has_value());  // off (ratio 1): one of the two rooms
  EXPECT_FALSE(found.alias.has_value());

  LoopSearchParams ambiguity = wide;
  ambiguity.ambiguity_ratio = 0.9;
  const SubmapSearch ambiguous = matchNodeToSubmap(submap, 99, scan, between, ambiguity);
  EXPECT_FALSE(ambiguous.loop.has_value());
  ASSERT_TRUE(ambiguous.alias.has_value());
  // The alias is the other room's pose: 14 m from the truth or on it.
  const double from_truth = (ambiguous.alias->pose.head<2>() - truth.head<2>()).norm();
  const double from_next_door =
      (ambiguous.alias->pose.head<2>() - truth.head<2>() - next_door).norm();
  EXPECT_LT(std::min(from_truth, from_next_door), 0.1) << ambiguous.alias->pose.transpose();
  EXPECT_GT(ambiguous.alias->score, 0.9 * found.loop->score);

  // A window that holds one room only: the match is unique there.
  const SubmapSearch unique =
      matchNodeToSubmap(submap, 99, scan, truth + core::Pose2(0.5, -0.4, 0.1), ambiguity);
  ASSERT_TRUE(unique.loop.has_value());
  EXPECT_FALSE(unique.alias.has_value());
  const core::Pose2 at =
      core::compose(submap.members()[static_cast<std::size_t>(unique.loop->from)].local_pose,
                    unique.loop->measurement);
  EXPECT_LT((at.head<2>() - truth.head<2>()).norm(), 0.05) << at.transpose();
  // The whole-submap search of relocalization sees both rooms.
  EXPECT_FALSE(matchNodeToWholeSubmap(submap, 99, scan, ambiguity).loop.has_value());
  EXPECT_TRUE(matchNodeToWholeSubmap(submap, 99, scan, off).loop.has_value());
}

TEST(TrajectoryRefinement, PullsPerturbedPosesBackOntoTheMap) {
  const RangeScanParams scan_params;
  const Submap submap = buildSubmap(SubmapParams{}, scan_params);
  std::vector<core::Pose2> truth, perturbed;
  std::vector<PointCloud> points;
  for (int k = 0; k < 40; ++k) {
    truth.emplace_back(2.5 + 0.12 * k, 1.5 + 0.05 * k, -0.5 + 0.03 * k);
    points.push_back(matchingPoints(castScan(room(), truth.back()), scan_params));
    // Deterministic errors of up to 3 cm and 1 degree, in every direction.
    perturbed.push_back(truth.back() + core::Pose2(0.03 * std::cos(1.7 * k),
                                                   0.03 * std::sin(2.3 * k),
                                                   0.017 * std::sin(0.9 * k)));
  }
  // One scan too sparse to match keeps its pose.
  points[5].resize(3);
  const auto refined = refineTrajectory(submap.matchGrid(), points, perturbed, {});
  ASSERT_EQ(refined.size(), truth.size());
  EXPECT_EQ(refined[5], perturbed[5]);
  // The rotation prior (weight 10) holds the angle more firmly than the translation.
  double before = 0.0, after = 0.0, before_rad = 0.0, after_rad = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    if (k == 5) continue;
    before += (perturbed[k].head<2>() - truth[k].head<2>()).norm();
    after += (refined[k].head<2>() - truth[k].head<2>()).norm();
    before_rad += std::abs(core::normalizeAngle(perturbed[k].z() - truth[k].z()));
    after_rad += std::abs(core::normalizeAngle(refined[k].z() - truth[k].z()));
    EXPECT_LT((refined[k].head<2>() - truth[k].head<2>()).norm(), 0.03) << "scan " << k;
    EXPECT_NEAR(core::normalizeAngle(refined[k].z() - truth[k].z()), 0.0, 0.012) << "scan " << k;
  }
  EXPECT_LT(after, 0.5 * before);
  EXPECT_LT(after_rad, 0.7 * before_rad);
  EXPECT_THROW(refineTrajectory(submap.matchGrid(), points, {truth[0]}, {}), std::invalid_argument);
}

class LocalSlamTest : public ::testing::TestWithParam<LocalSlamParams::Refinement> {};

TEST_P(LocalSlamTest, TracksARobotDrivingThroughTheRoomDespiteBiasedOdometry) {
  LocalSlamParams params;
  params.refinement = GetParam();
  params.submap.scans_per_submap = 10;
  LocalSlam slam(params);
  core::Pose2 odom = core::Pose2::Zero();
  core::Pose2 truth(2.0, 2.0, 0.0);
  core::Pose2 last_truth = truth;
  core::Pose2 first_local = core::Pose2::Zero();
  for (int k = 0; k < 60; ++k) {
    truth = core::Pose2(2.0 + 0.12 * k, 2.0 + 0.05 * k, 0.02 * k);
    // Odometry overestimates every step by 10% and turns 0.5 degree too much.
    core::Pose2 step = core::between(last_truth, truth);
    step.head<2>() *= 1.1;
    step.z() += 0.5 * M_PI / 180;
    odom = core::compose(odom, step);
    last_truth = truth;
    const LocalSlamResult r = slam.addScan(castScan(room(), truth), odom);
    if (k == 0) first_local = r.local_pose;
    // local pose = truth expressed from the first scan's frame, placed at the first odometry pose
    const core::Pose2 expected =
        core::compose(first_local, core::between(core::Pose2(2.0, 2.0, 0.0), truth));
    // ICP matches cell centres, so it is allowed half a cell more.
    const double tolerance = GetParam() == LocalSlamParams::Refinement::kIcp ? 0.075 : 0.05;
    EXPECT_LT((r.local_pose.head<2>() - expected.head<2>()).norm(), tolerance) << "scan " << k;
    EXPECT_NEAR(core::normalizeAngle(r.local_pose.z() - expected.z()), 0.0, 0.01) << "scan " << k;
  }
  EXPECT_GT(slam.numNodes(), 10);
  EXPECT_GE(slam.submaps().numSubmaps(), 3);
}

// A trajectory's first metres along a corridor of plain walls (its ends beyond the laser's range),
// the odometry exact: matched against a submap of one or a few scans, a point beyond what they saw
// scored as suspect as a wall's free side pulls each scan back inside, and the robot stays put.
double corridorStartTravel(const SubmapParams& submap) {
  // Walls 2.2 m apart with a door post every 4 m (the laser sees 8 m).
  std::vector<testing::Segment> corridor = {{{-50, -1}, {50, -1}}, {{-50, 1.2}, {50, 1.2}}};
  for (double x = -48.0; x < 50.0; x += 4.0) corridor.push_back({{x, 1.2}, {x, 1.0}});
  LocalSlamParams params;
  params.submap = submap;
  LocalSlam slam(params);
  core::Pose2 local = core::Pose2::Zero();
  for (int k = 0; k < 40; ++k) {  // 0.07 m per scan, 0.1 s apart: at speed from the first
    const core::Pose2 truth(0.07 * k, 0.0, 0.0);
    RangeScan scan = castScan(corridor, truth, 8.0);
    scan.timestamp = 0.1 * k;
    local = slam.addScan(scan, truth).local_pose;
  }
  return local.x();
}

TEST(LocalSlam, UnobservedCellsAtTheOccupancyPriorLetATrajectoryStartAlongACorridor) {
  const double travel = 0.07 * 39;
  SubmapParams prior;
  prior.active_unknown_value = 0.5;
  EXPECT_NEAR(corridorStartTravel(prior), travel, 0.05 * travel);
  // Unobserved cells scored as the loop search scores them (0.1): held back.
  SubmapParams suspect;
  suspect.active_unknown_value = 0.1;
  suspect.young_submap_scans = 0;
  EXPECT_LT(corridorStartTravel(suspect), 0.5 * travel);
  // At the prior while the submap is young only.
  SubmapParams young = suspect;
  young.young_submap_scans = 10;
  young.young_unknown_value = 0.5;
  EXPECT_NEAR(corridorStartTravel(young), travel, 0.05 * travel);
}

LocalSlamParams youngStartParams(double start_speed) {
  LocalSlamParams params;
  params.young_submap_start_speed = start_speed;
  params.motion_filter = core::KeyframeParams{0.1, 2.0 * M_PI / 180};
  params.submap.young_submap_scans = 20;
  params.submap.young_unknown_value = 0.5;
  params.submap.active_unknown_value = 0.1;
  return params;
}

// What never-observed cells of the first submap score after the session's third scan: the
// occupancy prior (0.5) while it is young, 0.1 otherwise. The robot stands for `standing` scans,
// then drives at `speed` m/s; scans `interval` s apart, the second at the first's stamp if
// `same_stamp` (a logger's duplicate).
float thirdScanUnknownScore(double start_speed, int standing, double speed, double interval = 0.1,
                            bool same_stamp = false) {
  LocalSlam slam(youngStartParams(start_speed), 0, 4);  // continuing a map of four submaps
  for (int k = 0; k < 3; ++k) {
    const double t = interval * std::max(0, k - (same_stamp ? 1 : 0));
    const core::Pose2 truth(3.0 + speed * std::max(0.0, t - interval * standing), 3.0, 0.0);
    RangeScan scan = castScan(room(), truth);
    scan.timestamp = 100.0 + t;
    slam.addScan(scan, truth);
  }
  return slam.submaps().matchingSubmap()->matchGrid().unknown();
}

TEST(LocalSlam, ASessionsFirstSubmapIsYoungOnlyWhenTheSessionStartsAtSpeed) {
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 0, 0.5), 0.5F);   // at speed from the first scan
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 1, 0.5), 0.1F);   // from rest, then at speed
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 0, 0.04), 0.1F);  // creeping: as from rest
  // 0.25 m in 0.5 s is 0.5 m/s: at the threshold is from rest, just above is at speed.
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.5, 0, 0.5, 0.5), 0.1F);
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.49, 0, 0.5, 0.5), 0.5F);
  // A duplicate stamp judges nothing; the next interval does.
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 0, 0.5, 0.1, true), 0.5F);
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 1, 0.5, 0.1, true), 0.1F);
  // Stamps that give no interval (all alike), or a gap of the log: as from rest.
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 0, 0.5, 0.0), 0.1F);
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.05, 0, 0.5, 2.0), 0.1F);
  EXPECT_FLOAT_EQ(thirdScanUnknownScore(0.0, 3, 0.0), 0.5F);  // 0: every session's first submap
  // A checkpoint, taken after the judgement or before it, resumes as it was.
  for (const int standing : {0, 1}) {
    const LocalSlamParams params = youngStartParams(0.05);
    LocalSlam slam(params);
    std::optional<LocalSlam::Checkpoint> unjudged;
    for (int k = 0; k < 2; ++k) {
      const core::Pose2 truth(3.0 + 0.05 * std::max(0, k - standing), 3.0, 0.0);
      RangeScan scan = castScan(room(), truth);
      scan.timestamp = 0.1 * k;
      if (k == 1) unjudged = slam.checkpoint();
      slam.addScan(scan, truth);
      ASSERT_EQ(slam.numNodes(), 1);  // 0.05 m: the second scan is no node
    }
    const float judged = slam.submaps().matchingSubmap()->matchGrid().unknown();
    EXPECT_FLOAT_EQ(judged, standing == 0 ? 0.5F : 0.1F);
    const auto first = toObservation(castScan(room(), core::Pose2(3.0, 3.0, 0.0)), params.scan);
    const auto scan_of = [&](int) -> const mrpt::obs::CObservation2DRangeScan& { return first; };
    const LocalSlam resumed = LocalSlam::resume(slam.checkpoint(), 0, 0, scan_of);
    EXPECT_FLOAT_EQ(resumed.submaps().matchingSubmap()->matchGrid().unknown(), judged);
    LocalSlam replayed = LocalSlam::resume(*unjudged, 0, 0, scan_of);
    EXPECT_FLOAT_EQ(replayed.submaps().matchingSubmap()->matchGrid().unknown(), 0.1F);
    const core::Pose2 truth(3.0 + 0.05 * (1 - standing), 3.0, 0.0);
    RangeScan scan = castScan(room(), truth);
    scan.timestamp = 0.1;
    replayed.addScan(scan, truth);
    EXPECT_FLOAT_EQ(replayed.submaps().matchingSubmap()->matchGrid().unknown(), judged);
  }
}

TEST(LocalSlam, RefusesImplausibleScansAndTracksOnAfterAnOdometryJump) {
  LocalSlamParams params;
  params.submap.scans_per_submap = 10;
  LocalSlam slam(params);
  core::Pose2 odom = core::Pose2::Zero();
  auto truthAt = [](int k) { return core::Pose2(2.0 + 0.1 * k, 2.0 + 0.04 * k, 0.01 * k); };
  core::Pose2 last_truth = truthAt(0), first_local = core::Pose2::Zero();
  for (int k = 0; k < 40; ++k) {
    const core::Pose2 truth = truthAt(k);
    odom = core::compose(odom, core::between(last_truth, truth));
    last_truth = truth;
    if (k == 20) {
      // A wheel slip of 1 km: refused, and the odometry goes on from there.
      odom.x() += 1000.0;
      EXPECT_THROW(slam.addScan(castScan(room(), truth), odom), ScanRefused);
      continue;
    }
    if (k == 25) {
      // Nonsense that must never reach MRPT's grids: each refused, nothing changes.
      const int nodes = slam.numNodes();
      for (const core::Pose2& bad :
           {core::Pose2(1e300, 0.0, 0.0), core::Pose2(NAN, 0.0, 0.0), core::Pose2(2e6, 0.0, 0.0)}) {
        EXPECT_THROW(slam.addScan(castScan(room(), truth), bad), ScanRefused);
      }
      RangeScan far_laser = castScan(room(), truth);
      far_laser.laser_in_robot = core::Pose2(1e7, 0.0, 0.0);
      EXPECT_THROW(slam.addScan(far_laser, odom), ScanRefused);
      EXPECT_EQ(slam.numNodes(), nodes);
    }
    const LocalSlamResult r = slam.addScan(castScan(room(), truth), odom);
    if (k == 0) first_local = r.local_pose;
    const core::Pose2 expected = core::compose(first_local, core::between(truthAt(0), truth));
    // The step across the jump is lost and found again by matching, at some centimetres' cost.
    const double tolerance = k < 20 ? 0.05 : 0.1;
    EXPECT_LT((r.local_pose.head<2>() - expected.head<2>()).norm(), tolerance) << "scan " << k;
  }
  try {
    LocalSlam fresh(params);
    fresh.addScan(castScan(room(), truthAt(0)), core::Pose2::Zero());
    fresh.addScan(castScan(room(), truthAt(1)), core::Pose2(6.0, 0.0, 0.0));
    FAIL() << "a 6 m step accepted";
  } catch (const ScanRefused& e) {
    EXPECT_NE(std::string(e.what()).find("odometry moved 6 m since the previous scan "
                                         "(scan_max_odometry_jump 5 m)"),
              std::string::npos)
        << e.what();
  }
}

// The largest local-pose error of a robot that drives 2 m forward and then backs up 1.5 m, scans
// 0.1 s apart (`stop`: slowing down and starting again over three scans; else reversing from one
// scan to the next). `odometry_reports_forward`: the odometry integrates the speed's magnitude,
// so each backing step is predicted 0.2 m off (the FR079 log's base does this).
double worstErrorBackingUp(bool velocity_prediction, bool stop, bool odometry_reports_forward,
                           int* velocity_predicted) {
  LocalSlamParams params;
  params.submap.scans_per_submap = 10;
  params.velocity_prediction = velocity_prediction;
  LocalSlam slam(params);
  std::vector<double> steps(20, 0.1);
  if (stop) {
    for (double s : {0.05, 0.0, -0.05}) steps.push_back(s);
  }
  steps.insert(steps.end(), stop ? 14 : 15, -0.1);
  core::Pose2 truth(1.5, 4.0, 0.0), odom = truth;
  core::Pose2 first_local = core::Pose2::Zero();
  double worst = 0.0;
  *velocity_predicted = 0;
  for (std::size_t k = 0; k <= steps.size(); ++k) {
    if (k > 0) {
      truth.x() += steps[k - 1];
      odom.x() += odometry_reports_forward ? std::abs(steps[k - 1]) : steps[k - 1];
    }
    RangeScan scan = castScan(room(), truth);
    scan.timestamp = 100.0 + 0.1 * static_cast<double>(k);
    const LocalSlamResult r = slam.addScan(scan, odom);
    if (k == 0) first_local = r.local_pose;
    const core::Pose2 expected =
        core::compose(first_local, core::between(core::Pose2(1.5, 4.0, 0.0), truth));
    worst = std::max(worst, (r.local_pose.head<2>() - expected.head<2>()).norm());
    *velocity_predicted += r.velocity_predicted ? 1 : 0;
  }
  return worst;
}

TEST(LocalSlam, FollowsARobotBackingUpWhileItsOdometrySaysForward) {
  int velocity_predicted = 0;
  EXPECT_LT(worstErrorBackingUp(true, true, true, &velocity_predicted), 0.05);
  EXPECT_GE(velocity_predicted, 10);  // every backing step after the first ones
  // Searched around the odometry alone, the backing scans are held near the window's edge.
  EXPECT_GT(worstErrorBackingUp(false, true, true, &velocity_predicted), 0.3);
  EXPECT_EQ(velocity_predicted, 0);
}

TEST(LocalSlam, KeepsTrueOdometryWhenTheRobotReversesAtOnce) {
  // The velocity prediction is 0.2 m off at the reversal and searched; the odometry's window,
  // which holds the truth, must win.
  int velocity_predicted = 0;
  EXPECT_LT(worstErrorBackingUp(true, false, false, &velocity_predicted), 0.05);
  EXPECT_EQ(velocity_predicted, 0);
}
INSTANTIATE_TEST_SUITE_P(Refinements, LocalSlamTest,
                         ::testing::Values(LocalSlamParams::Refinement::kLeastSquares,
                                           LocalSlamParams::Refinement::kIcp),
                         [](const auto& param_info) {
                           return param_info.param == LocalSlamParams::Refinement::kIcp
                                      ? std::string("Icp")
                                      : std::string("LeastSquares");
                         });

TEST(ActiveSubmaps, TwoActiveHalfOverlappingSubmapsOfFixedSize) {
  SubmapParams params;
  params.scans_per_submap = 4;
  ActiveSubmaps submaps(params);
  const auto scan = toObservation(castScan(room(), core::Pose2(3, 3, 0)), RangeScanParams{});
  std::vector<std::shared_ptr<Submap>> finished;
  for (int node = 0; node < 12; ++node) {
    if (auto f = submaps.insert(scan, core::Pose2(3, 3, 0), node)) finished.push_back(f);
    EXPECT_LE(submaps.active().size(), 2U);
  }
  // Submaps start at nodes 0, 2, 4, 6, ...; each holds 4 scans.
  ASSERT_EQ(finished.size(), 5U);
  for (std::size_t k = 0; k < finished.size(); ++k) {
    EXPECT_EQ(finished[k]->anchorNode(), static_cast<int>(2 * k));
    EXPECT_EQ(finished[k]->lastNode(), static_cast<int>(2 * k + 3));
    EXPECT_EQ(finished[k]->numScans(), 4);
    EXPECT_TRUE(finished[k]->finished());
  }
}

TEST(ActiveSubmaps, OnlyTheSessionsFirstSubmapIsYoung) {
  SubmapParams params;
  params.scans_per_submap = 8;
  params.young_submap_scans = 20;  // more than any submap here ever holds: young while half full
  params.young_unknown_value = 0.5;
  params.active_unknown_value = 0.1;
  ActiveSubmaps submaps(params, 7);  // a session whose first submap is the map's 8th
  submaps.startYouth();
  const auto scan = toObservation(castScan(room(), core::Pose2(3, 3, 0)), RangeScanParams{});
  std::vector<std::tuple<int, int, float>> matched;  // submap index, its scans, unknowns' score
  for (int node = 0; node < 20; ++node) {
    submaps.insert(scan, core::Pose2(3, 3, 0), node);
    const auto m = submaps.matchingSubmap();
    matched.emplace_back(m->index(), m->numScans(), m->matchGrid().unknown());
  }
  int young = 0;
  for (const auto& [index, scans, unknown] : matched) {
    EXPECT_FLOAT_EQ(unknown, index == 7 && scans < 4 ? 0.5F : 0.1F) << "submap " << index;
    young += unknown == 0.5F;
  }
  EXPECT_EQ(young, 3);
  EXPECT_EQ(std::get<0>(matched.front()), 7);
  EXPECT_GE(std::get<0>(matched.back()), 9);
  // Rebuilt after trimming (two earlier sessions' submaps gone): the same rule, renumbered.
  ActiveSubmaps first(params, 7);
  first.startYouth();
  first.insert(scan, core::Pose2(3, 3, 0), 0);
  first.rebuild(first.contents(), 0, 2,
                [&](int) -> const mrpt::obs::CObservation2DRangeScan& { return scan; });
  ASSERT_EQ(first.matchingSubmap()->index(), 5);
  EXPECT_FLOAT_EQ(first.matchingSubmap()->matchGrid().unknown(), 0.5F);
  for (int node = 1; node < 8; ++node) first.insert(scan, core::Pose2(3, 3, 0), node);
  ASSERT_EQ(first.matchingSubmap()->index(), 6);
  EXPECT_FLOAT_EQ(first.matchingSubmap()->matchGrid().unknown(), 0.1F);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
