#include "rrr_graphslam/frontend/local_slam.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace rrr_graphslam::frontend {

LocalSlam::LocalSlam(const LocalSlamParams& params, int first_node, int first_submap)
    : params_(params),
      submaps_(params.submap, first_submap),
      motion_filter_(params.motion_filter),
      next_node_(first_node) {
  if (params_.young_submap_start_speed <= 0.0) {  // every session's first submap is young
    start_judged_ = true;
    submaps_.startYouth();
  }
}

namespace {

std::string format(const core::Pose2& p) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.6g, %.6g, %.6g)", p.x(), p.y(), p.z());
  return text;
}

}  // namespace

void LocalSlam::checkPlausible(const RangeScan& scan, const core::Pose2& odom_pose) {
  if (!odom_pose.allFinite() || odom_pose.head<2>().cwiseAbs().maxCoeff() > kMaxCoordinate) {
    throw ScanRefused("odometry pose " + format(odom_pose) + " is not finite or beyond " +
                      std::to_string(static_cast<int>(kMaxCoordinate)) + " m");
  }
  if (!plausibleLaserPose(scan.laser_in_robot)) {
    throw ScanRefused("laser pose in the robot frame " + format(scan.laser_in_robot) +
                      " is not finite or more than 100 m from the robot");
  }
  if (!started_) return;
  const double jump = (odom_pose.head<2>() - last_odom_.head<2>()).norm();
  if (jump > params_.max_odometry_jump_m) {
    last_odom_ = odom_pose;  // re-anchored: the next scans are tracked from here
    char text[160];
    std::snprintf(text, sizeof text,
                  "odometry moved %.6g m since the previous scan (scan_max_odometry_jump %.6g m): "
                  "scan refused, odometry re-anchored at it",
                  jump, params_.max_odometry_jump_m);
    throw ScanRefused(text);
  }
}

std::optional<core::Pose2> LocalSlam::velocityPrediction(double stamp) const {
  // Older than this, a velocity says nothing about the next scan (the robot may have stopped).
  constexpr double kMaxIntervalSeconds = 1.0;
  if (!params_.velocity_prediction || !last_motion_) return std::nullopt;
  const double seconds = stamp - last_stamp_;
  const double last_seconds = last_motion_->seconds;
  // Intervals further apart than this factor say more about the stamps (jitter, bursts of a
  // logger, a near-duplicate) than about the motion: no prediction.
  constexpr double kMaxIntervalRatio = 2.0;
  if (!(seconds > 0.0 && seconds <= kMaxIntervalSeconds && last_seconds > 0.0 &&
        last_seconds <= kMaxIntervalSeconds)) {
    return std::nullopt;
  }
  const double ratio = seconds / last_seconds;
  if (ratio > kMaxIntervalRatio || ratio < 1.0 / kMaxIntervalRatio) return std::nullopt;
  // x, y and theta scaled alike: exact for equal intervals, off to second order otherwise.
  return core::compose(last_local_, last_motion_->step * ratio);
}

LocalSlam::WindowMatch LocalSlam::searchWindows(const MatchGrid& grid, const PointCloud& points,
                                                double stamp, const core::Pose2& prediction) const {
  // The velocity prediction's match must score this much better than the odometry's: the
  // odometry is right far more often, and a second window is a second chance for a corridor's
  // repeated structure.
  constexpr double kVelocityMinGain = 1.1;
  const CorrelativeParams& window = params_.correlative;
  const CorrelativeMatch odometry = realTimeCorrelativeMatch(grid, prediction, points, window);
  const WindowMatch by_odometry{odometry.pose, prediction};
  const std::optional<core::Pose2> velocity = velocityPrediction(stamp);
  if (!velocity) return by_odometry;
  // Within half a window of each other, the odometry's window already covers the velocity
  // prediction's neighbourhood.
  const bool disagree =
      (velocity->head<2>() - prediction.head<2>()).norm() > 0.5 * window.linear_window_m ||
      std::abs(core::normalizeAngle(velocity->z() - prediction.z())) >
          0.5 * window.angular_window_rad;
  if (!disagree) return by_odometry;
  const CorrelativeMatch by_velocity = realTimeCorrelativeMatch(grid, *velocity, points, window);
  if (by_velocity.score <= kVelocityMinGain * odometry.score) return by_odometry;
  return {by_velocity.pose, *velocity, true};
}

void LocalSlam::judgeStart(double stamp, const core::Pose2& odom_pose) {
  // An interval the stamps make meaningless (none, backwards, a gap in the log) judges nothing:
  // the next one does, and until then the first submap is matched as from rest.
  constexpr double kMaxJudgedIntervalSeconds = 1.0;
  const double seconds = stamp - last_stamp_;
  if (!(seconds > 0.0 && seconds <= kMaxJudgedIntervalSeconds)) return;
  start_judged_ = true;
  const double travel = (odom_pose.head<2>() - last_odom_.head<2>()).norm();
  if (travel > params_.young_submap_start_speed * seconds) submaps_.startYouth();
}

LocalSlamResult LocalSlam::addScan(const RangeScan& scan, const core::Pose2& odom_pose) {
  checkPlausible(scan, odom_pose);
  LocalSlamResult result;
  const bool first = !started_;
  const core::Pose2 prediction =
      first ? odom_pose : core::compose(last_local_, core::between(last_odom_, odom_pose));
  started_ = true;
  if (!first && !start_judged_) judgeStart(scan.timestamp, odom_pose);
  result.local_pose = prediction;
  result.points = matchingPoints(scan, params_.scan);

  const auto submap = submaps_.matchingSubmap();
  if (submap && static_cast<int>(result.points.size()) >= params_.min_points) {
    const MatchGrid& grid = submap->matchGrid();
    const WindowMatch match = params_.correlative.linear_window_m > 0.0
                                  ? searchWindows(grid, result.points, scan.timestamp, prediction)
                                  : WindowMatch{prediction, prediction};
    const core::Pose2& initial = match.pose;
    result.velocity_predicted = match.velocity_predicted;
    if (params_.refinement == LocalSlamParams::Refinement::kIcp && submap->grid() != nullptr) {
      const auto icp = refineIcp(*submap->grid(), initial, result.points, params_.icp);
      result.local_pose = icp.value_or(initial);
    } else {
      // Cartographer's choice: translation pulled toward the prediction (of the window the match
      // came from), rotation toward the correlative result.
      const core::Pose2 prior(match.center.x(), match.center.y(), initial.z());
      result.local_pose =
          refineLeastSquares(grid, prior, initial, result.points, params_.least_squares).pose;
    }
    result.matched = true;
  }
  if (!first) {
    last_motion_ =
        Motion{core::between(last_local_, result.local_pose), scan.timestamp - last_stamp_};
  }
  last_stamp_ = scan.timestamp;
  last_local_ = result.local_pose;
  last_odom_ = odom_pose;

  if (motion_filter_.accept(result.local_pose)) {
    const int node = next_node_++;
    result.node = node;
    result.observation = toObservation(scan, params_.scan);
    result.finished_submap = submaps_.insert(*result.observation, result.local_pose, node);
  }
  return result;
}

LocalSlam::Checkpoint LocalSlam::checkpoint() const {
  Checkpoint checkpoint{*this, submaps_.contents()};
  checkpoint.state.submaps_.rebuild({}, 0, 0, nullptr);  // shares no submap with this one
  return checkpoint;
}

LocalSlam LocalSlam::resume(const Checkpoint& checkpoint, int node_shift, int submap_shift,
                            const ActiveSubmaps::ScanOf& scan_of) {
  LocalSlam slam = checkpoint.state;
  slam.submaps_.rebuild(checkpoint.active, node_shift, submap_shift, scan_of);
  slam.next_node_ -= node_shift;
  return slam;
}

}  // namespace rrr_graphslam::frontend
