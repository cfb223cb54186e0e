// Lifelong trimming of a map: submaps that newer ones cover leave with their nodes, whose
// information stays as marginal edges; the trimmed map saves, loads and continues like any other;
// pending loops make their submaps wait; the Chow-Liu tree loses far less than deletion.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/frontend/online_trimmer.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

using testing::castScan;
using testing::drive;
using testing::room;
using testing::roomSizedParams;
using testing::truthAt;

// Three laps of the room: the last laps' submaps cover the first lap's.
const MapSnapshot& threeLaps() {
  static const MapSnapshot map = [] {
    LaserSlam slam(roomSizedParams(), "laps");
    drive(slam, core::Pose2::Zero(), 320, 0.0);
    slam.finish();
    return slam.snapshot();
  }();
  return map;
}

// threeLaps() is one session: its own submaps are judged (keep_current_session would keep them).
TrimParams trimParams() {
  TrimParams p;
  p.trim_overlap_ratio = 0.8;
  p.keep_recent_submaps = 3;
  p.keep_current_session = false;
  p.threads = 1;
  p.report_kl = true;
  return p;
}

int countKind(const MapSnapshot& map, MapSnapshot::EdgeKind kind) {
  int n = 0;
  for (const auto& e : map.edges) n += e.kind == kind;
  return n;
}

TEST(MapTrimming, CoveredSubmapsLeaveAndTheirNodesBecomeMarginalEdges) {
  const MapSnapshot& map = threeLaps();
  ASSERT_GT(map.submaps.size(), 10u);
  const TrimResult trimmed = trimMap(map, trimParams(), roomSizedParams().local.submap);
  const TrimReport& report = trimmed.report;
  EXPECT_GT(report.trimmed_submaps, 0);
  ASSERT_FALSE(report.trims.empty());
  EXPECT_EQ(trimmed.map.submaps.size() + static_cast<std::size_t>(report.trimmed_submaps),
            map.submaps.size());
  EXPECT_EQ(trimmed.map.nodes.size() + static_cast<std::size_t>(report.removedNodes()),
            map.nodes.size());
  EXPECT_EQ(countKind(trimmed.map, MapSnapshot::EdgeKind::kMarginal), report.marginal_edges_kept);
  EXPECT_GT(report.marginal_edges_kept, 0);
  EXPECT_GE(report.marginalEdges(), report.marginal_edges_kept);
  EXPECT_EQ(trimmed.map.lifelong.trimmed_submaps, report.trimmed_submaps);
  EXPECT_EQ(trimmed.map.lifelong.marginalized_nodes, report.removedNodes());
  // The newest submaps stay; every kept submap keeps all its nodes (check() holds the spans).
  EXPECT_NO_THROW(trimmed.map.check());
  EXPECT_EQ(trimmed.map.submaps.back().last_node + 1, static_cast<int>(trimmed.map.nodes.size()));
  for (const TrimRecord& t : report.trims) {
    EXPECT_LT(t.submap, static_cast<int>(map.submaps.size()) - trimParams().keep_recent_submaps);
    EXPECT_GT(t.removed_nodes, 0);
    // A tree over the blanket: |B| - 1 edges per connected piece.
    EXPECT_LE(t.marginal_edges, t.blanket_nodes - 1);
    // Both divergences are measured, and the (conservative) tree never loses more than deletion.
    EXPECT_GT(t.kl_delete_nats, 0.0) << "submap " << t.submap;
    EXPECT_TRUE(std::isfinite(t.kl_delete_nats)) << "submap " << t.submap;
    EXPECT_GT(t.kl_clt_nats, 0.0) << "submap " << t.submap;
    EXPECT_LE(t.kl_clt_nats, t.kl_delete_nats * (1.0 + 1e-9)) << "submap " << t.submap;
    EXPECT_EQ(t.kl_nats, t.kl_clt_nats);
  }
  // Why conservative: in this room (three laps of near-perfect scans) the later laps hold the
  // blankets so tightly that deleting loses little, and the plain Chow-Liu tree, which states up
  // to several times the marginal's information along some directions, loses more than deleting
  // in several trims, and over the run about 3x what the conservative tree loses (15.4 against
  // 5.6 nats when written).
  TrimParams plain_params = trimParams();
  plain_params.chow_liu.conservative = false;
  const TrimReport plain = trimMap(map, plain_params, roomSizedParams().local.submap).report;
  int plain_worse = 0;
  double plain_total = 0.0, conservative_total = 0.0;
  for (const TrimRecord& t : plain.trims) {
    plain_worse += t.kl_clt_nats > t.kl_delete_nats;
    plain_total += t.kl_clt_nats;
  }
  for (const TrimRecord& t : report.trims) conservative_total += t.kl_clt_nats;
  EXPECT_GT(plain_worse, 0);
  EXPECT_LT(conservative_total, 0.5 * plain_total);
  // Trimming again with the same rule finds nothing more to trim among the kept submaps' cover.
  const TrimResult again = trimMap(trimmed.map, trimParams(), roomSizedParams().local.submap);
  EXPECT_LE(again.report.trimmed_submaps, report.trimmed_submaps);
}

// The trusted graph (odometry, accepted loops, marginal edges) at its minimum.
std::vector<core::Pose2> trustedOptimum(const MapSnapshot& map) {
  core::Optimizer optimizer = core::makeOptimizer(trustedPoseGraph(map));
  optimizer.optimize();
  return optimizer.poses();
}

// Every trim of a save linearizes at the one minimum found before the first: exact
// marginalization leaves the kept nodes' minimum where it was and the tree keeps the marginal's
// gradient, so after all the trims the trimmed graph's own minimum is still there. Deletion drops
// the removed constraints' pull on the blanket: its minimum moves.
TEST(MapTrimming, TheTreeLeavesTheKeptNodesAtTheirMinimum) {
  const MapSnapshot& map = threeLaps();
  const std::vector<core::Pose2> before = trustedOptimum(map);
  std::map<double, std::size_t> node_at;  // one session: timestamps are unique
  for (std::size_t k = 0; k < map.nodes.size(); ++k) node_at.emplace(map.nodes[k].timestamp, k);
  auto largestMove = [&](const MapSnapshot& trimmed) {
    // Up to the gauge: both frames put the first kept node where it was.
    const core::Pose2& first = before[node_at.at(trimmed.nodes[0].timestamp)];
    const core::Pose2 motion = core::compose(first, core::inverse(trimmed.nodes[0].map_pose));
    double largest = 0.0;
    for (const MapSnapshot::Node& node : trimmed.nodes) {
      const core::Pose2 moved = core::compose(motion, node.map_pose);
      largest = std::max(largest,
                         (moved.head<2>() - before[node_at.at(node.timestamp)].head<2>()).norm());
    }
    return largest;
  };
  TrimParams params = trimParams();
  params.report_kl = false;
  const TrimResult clt = trimMap(map, params, roomSizedParams().local.submap);
  ASSERT_GT(clt.report.trims.size(), 3u);
  EXPECT_EQ(clt.report.trims.front().kl_seconds, 0.0);
  const double clt_move = largestMove(clt.map);
  EXPECT_LT(clt_move, 1e-6);
  params.sparsification = Sparsification::kDelete;
  const double delete_move = largestMove(trimMap(map, params, roomSizedParams().local.submap).map);
  EXPECT_GT(delete_move, 10.0 * clt_move);
}

// The exact marginal kept as dense factors: nothing is lost at the trim (KL zero where the tree's
// and deletion's are not), the kept nodes stay at their minimum, and the map saves, loads and
// continues with its dense factors as it does with marginal edges.
TEST(MapTrimming, TheDenseMarginalIsExactAndContinues) {
  TrimParams params = trimParams();
  params.sparsification = Sparsification::kDense;
  params.keep_recent_submaps = 12;  // as TrimmedMapSavesLoadsAndContinues
  const MapSnapshot& map = threeLaps();
  const TrimResult dense = trimMap(map, params, roomSizedParams().local.submap);
  const TrimReport& report = dense.report;
  ASSERT_FALSE(report.trims.empty());
  EXPECT_EQ(report.marginalEdges(), 0);
  EXPECT_EQ(countKind(dense.map, MapSnapshot::EdgeKind::kMarginal), 0);
  EXPECT_GT(report.dense_factors_kept, 0);
  EXPECT_EQ(static_cast<int>(dense.map.dense_factors.size()), report.dense_factors_kept);
  for (const TrimRecord& t : report.trims) {
    EXPECT_GT(t.dense_factors, 0) << "submap " << t.submap;
    EXPECT_LT(t.kl_nats, 1e-6) << "submap " << t.submap;
    EXPECT_GT(t.kl_clt_nats, 1e3 * std::max(t.kl_nats, 1e-9)) << "submap " << t.submap;
  }
  // Later trims folded the earlier trims' factors they touched into their own: every factor left
  // is over nodes of the trimmed map, and the trimmed graph's minimum is the untrimmed one's.
  for (const core::DenseFactor& f : dense.map.dense_factors) {
    EXPECT_EQ(core::denseFactorProblem(f), "");
  }
  const std::vector<core::Pose2> before = trustedOptimum(map);
  const std::vector<core::Pose2> after = trustedOptimum(dense.map);
  std::map<double, std::size_t> node_at;
  for (std::size_t k = 0; k < map.nodes.size(); ++k) node_at.emplace(map.nodes[k].timestamp, k);
  const core::Pose2& first = before[node_at.at(dense.map.nodes[0].timestamp)];
  const core::Pose2 motion = core::compose(first, core::inverse(after[0]));
  double largest = 0.0;
  for (std::size_t k = 0; k < dense.map.nodes.size(); ++k) {
    const core::Pose2 moved = core::compose(motion, after[k]);
    largest = std::max(
        largest,
        (moved.head<2>() - before[node_at.at(dense.map.nodes[k].timestamp)].head<2>()).norm());
  }
  EXPECT_LT(largest, 1e-5);

  const std::string path = ::testing::TempDir() + "dense.rrrmap";
  writeMapFile(dense.map, path);
  const MapSnapshot read = readMapFile(path);
  ASSERT_EQ(read.dense_factors.size(), dense.map.dense_factors.size());
  for (std::size_t k = 0; k < read.dense_factors.size(); ++k) {
    const core::DenseFactor& a = read.dense_factors[k];
    const core::DenseFactor& b = dense.map.dense_factors[k];
    EXPECT_EQ(a.nodes, b.nodes);
    EXPECT_EQ(a.measurements, b.measurements);
    EXPECT_EQ(a.mean, b.mean);
    EXPECT_EQ(a.information, b.information);
    EXPECT_EQ(a.chi2_offset, b.chi2_offset);
  }
  // A version-4 file cannot hold them.
  MapSnapshot older = dense.map;
  older.format_version = 4;
  EXPECT_THROW(older.check(), std::invalid_argument);

  auto slam = LaserSlam::fromMap(read, roomSizedParams(), "next");
  const core::Pose2 odom_frame(3.0, -2.0, 0.7);
  drive(*slam, odom_frame, 150, 1000.0, 320);
  slam->finish();
  const MapSnapshot next = slam->snapshot();
  EXPECT_EQ(next.dense_factors.size(), read.dense_factors.size());
  ASSERT_TRUE(slam->tie().has_value()) << "the new session did not tie to the trimmed map";
  const core::Pose2 frame =
      core::compose(next.nodes[0].map_pose, core::inverse(read.nodes[0].map_pose));
  for (std::size_t k = 0; k < read.nodes.size(); ++k) {
    const core::Pose2 expected = core::compose(frame, read.nodes[k].map_pose);
    EXPECT_LT((next.nodes[k].map_pose.head<2>() - expected.head<2>()).norm(), 0.05) << k;
  }
  const int first_new = next.sessions.back().first_node;
  for (std::size_t k = static_cast<std::size_t>(first_new); k < next.nodes.size(); k += 10) {
    const core::Pose2 truth =
        core::compose(frame, core::compose(core::inverse(odom_frame), next.nodes[k].local_pose));
    EXPECT_LT((next.nodes[k].map_pose.head<2>() - truth.head<2>()).norm(), 0.1) << k;
  }
  // Trimmed again (the new session covers the old one): the factors it touches fold into the new
  // ones, and the result still checks.
  TrimParams again = params;
  again.keep_current_session = true;
  const TrimResult twice = trimMap(next, again, roomSizedParams().local.submap);
  EXPECT_NO_THROW(twice.map.check());
}

// Online trimming with the exact marginal: the running session goes on from a map whose trimmed
// part is dense factors, tied, where the untrimmed map has it.
TEST(MapTrimming, ARunningSessionTrimsToDenseFactorsAndGoesOn) {
  LaserSlamParams sparse = roomSizedParams();
  sparse.loops.search_every_n_nodes = 150;
  auto running = LaserSlam::fromMap(threeLaps(), sparse, "running");
  const core::Pose2 odom_frame(3.0, -2.0, 0.7);
  drive(*running, odom_frame, 200, 1000.0, 320);
  ASSERT_TRUE(running->tied());
  TrimParams params = trimParams();
  params.keep_current_session = true;
  params.sparsification = Sparsification::kDense;
  const LaserSlam::Trimmed trimmed = LaserSlam::trimmed(
      running->checkpoint(), params, OverlapRatioTrimming(params.trim_overlap_ratio));
  ASSERT_NE(trimmed.slam, nullptr);
  LaserSlam& next = *trimmed.slam;
  EXPECT_GT(trimmed.report.trimmed_submaps, 0);
  EXPECT_EQ(trimmed.report.marginalEdges(), 0);
  EXPECT_GT(trimmed.report.dense_factors_kept, 0);
  EXPECT_EQ(next.rrr().status().dense_factors, trimmed.report.dense_factors_kept);
  EXPECT_TRUE(next.tied());
  drive(*running, odom_frame, 80, 1000.0, 520);
  drive(next, odom_frame, 80, 1000.0, 520);
  running->finish();
  next.finish();
  EXPECT_TRUE(next.tied());
  const MapSnapshot a = running->snapshot();
  const MapSnapshot b = next.snapshot();
  EXPECT_EQ(static_cast<int>(b.dense_factors.size()), trimmed.report.dense_factors_kept);
  const std::size_t shift = a.nodes.size() - b.nodes.size();
  const core::Pose2 motion =
      core::compose(a.nodes.back().map_pose, core::inverse(b.nodes.back().map_pose));
  for (std::size_t k = static_cast<std::size_t>(b.sessions.back().first_node); k < b.nodes.size();
       k += 5) {
    const core::Pose2 expected = core::compose(motion, b.nodes[k].map_pose);
    EXPECT_LT((a.nodes[k + shift].map_pose.head<2>() - expected.head<2>()).norm(), 0.1) << k;
  }
  // Deletion is refused online: it would drop the session's loops to the map.
  OnlineTrimParams online;
  online.every_n_nodes = 100;
  online.trim.sparsification = Sparsification::kDelete;
  EXPECT_THROW(OnlineTrimmer{online}, std::invalid_argument);
  online.trim.sparsification = Sparsification::kDense;
  EXPECT_NO_THROW(OnlineTrimmer{online});
}

// A second session over the same room: by default its submaps all stay (the newest view of
// every cell it saw), the first session's that it covers go; judged all alike, the second
// session's own earlier submaps go too.
TEST(MapTrimming, TheCurrentSessionsSubmapsStay) {
  LaserSlam first(roomSizedParams(), "first");
  testing::drive(first, core::Pose2::Zero(), 210, 0.0);
  first.finish();
  auto second = LaserSlam::fromMap(first.snapshot(), roomSizedParams(), "second");
  testing::drive(*second, core::Pose2(1.0, -2.0, 0.3), 210, 1000.0);
  second->finish();
  const MapSnapshot map = second->snapshot();
  ASSERT_EQ(map.sessions.size(), 2u);
  // Sessions are renumbered when one leaves whole: told apart by name.
  auto ofSecond = [&](const MapSnapshot& m, const MapSnapshot::Submap& s) {
    const int session = m.nodes[static_cast<std::size_t>(s.first_node)].session;
    return m.sessions[static_cast<std::size_t>(session)].name == "second" ? 1 : 0;
  };
  int second_submaps = 0;
  for (const auto& s : map.submaps) second_submaps += ofSecond(map, s);
  TrimParams params = trimParams();
  params.keep_current_session = true;
  const TrimResult kept = trimMap(map, params, roomSizedParams().local.submap);
  EXPECT_GT(kept.report.trimmed_submaps, 0);
  int kept_second = 0;
  for (const auto& s : kept.map.submaps) kept_second += ofSecond(kept.map, s);
  EXPECT_EQ(kept_second, second_submaps);
  params.keep_current_session = false;
  const TrimResult judged = trimMap(map, params, roomSizedParams().local.submap);
  int judged_second = 0;
  for (const auto& s : judged.map.submaps) judged_second += ofSecond(judged.map, s);
  EXPECT_LT(judged_second, second_submaps);
  EXPECT_TRUE(TrimParams{}.keep_current_session);
}

TEST(MapTrimming, TrimmedMapSavesLoadsAndContinues) {
  TrimParams params = trimParams();
  params.keep_recent_submaps = 12;  // the last lap's loops to the second stay loops
  const TrimResult trimmed = trimMap(threeLaps(), params, roomSizedParams().local.submap);
  ASSERT_GT(trimmed.report.marginal_edges_kept, 0);
  const std::string path = ::testing::TempDir() + "trimmed.rrrmap";
  writeMapFile(trimmed.map, path);
  const MapSnapshot read = readMapFile(path);
  ASSERT_EQ(read.edges.size(), trimmed.map.edges.size());
  for (std::size_t k = 0; k < read.edges.size(); ++k) {
    EXPECT_EQ(read.edges[k].kind, trimmed.map.edges[k].kind) << k;
    EXPECT_EQ(read.edges[k].from, trimmed.map.edges[k].from) << k;
    EXPECT_EQ(read.edges[k].measurement, trimmed.map.edges[k].measurement) << k;
  }
  EXPECT_EQ(read.lifelong.trimmed_submaps, trimmed.map.lifelong.trimmed_submaps);
  EXPECT_EQ(read.lifelong.marginalized_nodes, trimmed.map.lifelong.marginalized_nodes);

  // A new session continues it: the marginal edges stay what they were, the map where it was.
  auto slam = LaserSlam::fromMap(read, roomSizedParams(), "next");
  EXPECT_EQ(slam->rrr().status().marginal_edges, countKind(read, MapSnapshot::EdgeKind::kMarginal));
  // Decided again at load, the loops the trimmed map kept are accepted again: the marginal edges
  // close cycles with the odometry (they carry the loops that bent it), and RRR's joint tests
  // measure what the loops add to that residual, not the residual itself.
  int kept_accepted = 0;
  for (const auto& e : read.edges) {
    kept_accepted +=
        e.kind == MapSnapshot::EdgeKind::kLoopCandidate && e.verdict == rrr::Verdict::kAccepted;
  }
  ASSERT_GT(kept_accepted, 0);
  EXPECT_EQ(slam->rrr().status().accepted, kept_accepted);
  const core::Pose2 odom_frame(3.0, -2.0, 0.7);
  drive(*slam, odom_frame, 150, 1000.0, 320);
  slam->finish();
  const MapSnapshot next = slam->snapshot();
  EXPECT_EQ(countKind(next, MapSnapshot::EdgeKind::kMarginal),
            countKind(read, MapSnapshot::EdgeKind::kMarginal));
  EXPECT_EQ(next.lifelong.trimmed_submaps, read.lifelong.trimmed_submaps);
  ASSERT_TRUE(slam->tie().has_value()) << "the new session did not tie to the trimmed map";
  // The loaded nodes stay where the trimmed map had them (up to the map's own gauge motion).
  const core::Pose2 motion =
      core::compose(next.nodes[0].map_pose, core::inverse(read.nodes[0].map_pose));
  for (std::size_t k = 0; k < read.nodes.size(); ++k) {
    const core::Pose2 expected = core::compose(motion, read.nodes[k].map_pose);
    EXPECT_LT((next.nodes[k].map_pose.head<2>() - expected.head<2>()).norm(), 0.05) << k;
  }
  // The new session's nodes lie on the truth (the map's frame is the first lap's odometry).
  const int first = next.sessions.back().first_node;
  for (std::size_t k = static_cast<std::size_t>(first); k < next.nodes.size(); k += 10) {
    const core::Pose2 truth =
        core::compose(motion, core::compose(core::inverse(odom_frame), next.nodes[k].local_pose));
    EXPECT_LT((next.nodes[k].map_pose.head<2>() - truth.head<2>()).norm(), 0.1) << k;
  }
}

// Online trimming: a running session trims the earlier ones and goes on exactly as it would have.
TEST(MapTrimming, ARunningSessionTrimsTheEarlierOnesAndGoesOnAsBefore) {
  // Each submap searched once in a while: the clusters of loops close behind the robot (in
  // this small room every submap is always in reach, and frequent searches keep them open).
  LaserSlamParams sparse = roomSizedParams();
  sparse.loops.search_every_n_nodes = 150;
  auto running = LaserSlam::fromMap(threeLaps(), sparse, "running");
  EXPECT_THROW(running->checkpoint(), std::logic_error);  // no node of its own yet
  const core::Pose2 odom_frame(3.0, -2.0, 0.7);
  drive(*running, odom_frame, 200, 1000.0, 320);
  ASSERT_TRUE(running->tied());
  const LaserSlam::Checkpoint checkpoint = running->checkpoint();
  TrimParams params = trimParams();
  params.keep_current_session = true;  // the running session stays whole
  const LaserSlam::Trimmed trimmed =
      LaserSlam::trimmed(checkpoint, params, OverlapRatioTrimming(params.trim_overlap_ratio));
  ASSERT_NE(trimmed.slam, nullptr);
  LaserSlam& next = *trimmed.slam;
  EXPECT_GT(trimmed.report.trimmed_submaps, 0);
  EXPECT_GT(trimmed.report.marginalEdges(), 0);

  // Loops to the map in clusters still open hold their submaps back.
  MapSnapshot open = checkpoint.map;
  const int open_first = open.sessions.back().first_node;
  for (auto& e : open.edges) {
    if ((e.from < open_first) != (e.to < open_first)) e.cluster = -1;
  }
  const TrimResult held =
      trimMap(open, params, roomSizedParams().local.submap, NewestSession::kRunning);
  EXPECT_GT(held.report.waiting_submaps, 0);
  EXPECT_LT(held.report.trimmed_submaps, trimmed.report.trimmed_submaps);
  EXPECT_EQ(held.map.nodes.size() - static_cast<std::size_t>(held.map.sessions.back().first_node),
            open.nodes.size() - static_cast<std::size_t>(open_first));  // the running one stays

  const MapSnapshot before = running->snapshot();
  const MapSnapshot after = next.snapshot();
  const int shift = static_cast<int>(before.nodes.size() - after.nodes.size());
  ASSERT_GT(shift, 0);
  ASSERT_EQ(after.sessions.back().name, "running");
  ASSERT_EQ(after.sessions.back().first_node, before.sessions.back().first_node - shift);
  EXPECT_EQ(after.lifelong.trimmed_submaps, trimmed.report.trimmed_submaps);
  EXPECT_TRUE(next.tied());
  EXPECT_EQ(next.sessions().back().name, "running");
  EXPECT_EQ(next.scanTimestamps().size(),
            running->scanTimestamps().size() - static_cast<std::size_t>(shift));
  EXPECT_EQ(next.sessionFirstScan(), running->sessionFirstScan() - static_cast<std::size_t>(shift));

  // Each kept submap's search sampling comes along under its new number, the rival reading's
  // (searched once a tied session's loops read it elsewhere) like the estimate's.
  {
    const LaserSlam::Checkpoint carried = next.checkpoint();
    EXPECT_TRUE(checkpoint.rival_search_state.empty());  // this session met no rival reading
    EXPECT_TRUE(carried.rival_search_state.empty());
    ASSERT_EQ(carried.search_state.size(), after.submaps.size() - carried.local.active.size());
    int searched = 0;
    for (const auto& s : carried.search_state) {
      if (s.last_searched < 0) continue;
      ++searched;
      EXPECT_LT(s.last_searched, static_cast<int>(after.nodes.size()));
      EXPECT_GE(s.last_searched, after.sessions.back().first_node);  // searched by this session
    }
    EXPECT_GT(searched, 0);
    LaserSlam::Checkpoint with_rival = checkpoint;
    with_rival.rival_search_state = checkpoint.search_state;
    for (std::size_t i = 0; i < with_rival.rival_search_state.size(); i += 2) {
      with_rival.rival_search_state[i] = {};  // never searched around the rival reading
    }
    const LaserSlam::Trimmed rival =
        LaserSlam::trimmed(with_rival, params, OverlapRatioTrimming(params.trim_overlap_ratio));
    ASSERT_NE(rival.slam, nullptr);
    const LaserSlam::Checkpoint r = rival.slam->checkpoint();
    ASSERT_EQ(r.rival_search_state.size(), carried.search_state.size());
    ASSERT_EQ(r.search_state.size(), carried.search_state.size());
    // Submap by submap: where the rival reading's state was the estimate's, it is carried to the
    // same numbers; where it was never searched, it stays so.
    int same = 0;
    int never = 0;
    for (std::size_t k = 0; k < r.rival_search_state.size(); ++k) {
      const auto& got = r.rival_search_state[k];
      const auto& estimate = r.search_state[k];
      EXPECT_EQ(estimate.last_searched, carried.search_state[k].last_searched) << k;
      EXPECT_EQ(estimate.last_matched, carried.search_state[k].last_matched) << k;
      if (estimate.last_searched < 0) continue;
      if (got.last_searched == estimate.last_searched &&
          got.last_matched == estimate.last_matched) {
        ++same;
      } else {
        EXPECT_LT(got.last_searched, 0) << k;  // one of those never searched around the rival
        EXPECT_LT(got.last_matched, 0) << k;
        ++never;
      }
    }
    EXPECT_GT(same, 0);
    EXPECT_GT(never, 0);
  }

  // Both go on with the same scans: local SLAM continues exactly where it was.
  drive(*running, odom_frame, 80, 1000.0, 520);
  drive(next, odom_frame, 80, 1000.0, 520);
  running->finish();
  next.finish();
  const MapSnapshot a = running->snapshot();
  const MapSnapshot b = next.snapshot();
  ASSERT_EQ(a.nodes.size() - b.nodes.size(), static_cast<std::size_t>(shift));
  ASSERT_EQ(a.submaps.size() - b.submaps.size(),
            static_cast<std::size_t>(trimmed.report.trimmed_submaps));
  for (std::size_t k = static_cast<std::size_t>(a.sessions.back().first_node); k < a.nodes.size();
       ++k) {
    const MapSnapshot::Node& mine = b.nodes[k - static_cast<std::size_t>(shift)];
    EXPECT_EQ(mine.local_pose, a.nodes[k].local_pose) << k;
    EXPECT_EQ(mine.timestamp, a.nodes[k].timestamp) << k;
  }
  EXPECT_EQ(next.stats().scans, running->stats().scans);
  EXPECT_TRUE(next.tied());
  // The running session lies where the untrimmed map has it (up to the gauge).
  const core::Pose2 motion =
      core::compose(a.nodes.back().map_pose, core::inverse(b.nodes.back().map_pose));
  for (std::size_t k = static_cast<std::size_t>(b.sessions.back().first_node); k < b.nodes.size();
       k += 5) {
    const core::Pose2 expected = core::compose(motion, b.nodes[k].map_pose);
    EXPECT_LT((a.nodes[k + static_cast<std::size_t>(shift)].map_pose.head<2>() - expected.head<2>())
                  .norm(),
              0.1)
        << k;
  }
  const std::string path = ::testing::TempDir() + "online_trimmed.rrrmap";
  writeMapFile(b, path);
  EXPECT_EQ(readMapFile(path).nodes.size(), b.nodes.size());
}

// The online trimmer: in line or behind the running map (the scans that came meanwhile given
// to the trimmed one), the running session goes on exactly as without trimming.
TEST(MapTrimming, TheOnlineTrimmerTrimsInLineOrBehindTheMap) {
  LaserSlamParams sparse = roomSizedParams();
  sparse.loops.search_every_n_nodes = 150;
  const core::Pose2 odom_frame(3.0, -2.0, 0.7);
  auto reference = LaserSlam::fromMap(threeLaps(), sparse, "running");
  drive(*reference, odom_frame, 280, 1000.0, 320);
  const MapSnapshot untrimmed = reference->snapshot();
  for (const bool in_line : {true, false}) {
    SCOPED_TRACE(in_line ? "in line" : "behind");
    TrimParams params = trimParams();
    params.keep_current_session = true;
    OnlineTrimmer trimmer({params, 100, in_line});
    std::unique_ptr<LaserSlam> slam = LaserSlam::fromMap(threeLaps(), sparse, "running");
    std::vector<OnlineTrimRecord> records;
    auto take = [&](std::unique_ptr<LaserSlam> trimmed) {
      if (trimmed) slam = std::move(trimmed);
      if (trimmer.finished() > static_cast<int>(records.size())) records.push_back(*trimmer.last());
    };
    for (int k = 320; k < 600; ++k) {
      RangeScan scan = castScan(room(), truthAt(k));
      scan.timestamp = 1000.0 + 0.1 * k;
      const core::Pose2 odom = core::compose(odom_frame, truthAt(k));
      const std::optional<int> node = slam->addScan(scan, odom);
      take(trimmer.afterScan(*slam, scan, odom, node));
    }
    take(trimmer.wait());
    ASSERT_FALSE(records.empty());
    EXPECT_GT(trimmer.replaced(), 0);
    const OnlineTrimRecord& first = records.front();
    EXPECT_GT(first.report.trimmed_submaps, 0);
    EXPECT_LT(first.nodes_after, first.nodes_before);
    if (in_line) {
      EXPECT_EQ(first.replayed_scans, 0);
    }
    const MapSnapshot map = slam->snapshot();
    const int first_node = map.sessions.back().first_node;
    const int untrimmed_first = untrimmed.sessions.back().first_node;
    ASSERT_EQ(map.nodes.size() - static_cast<std::size_t>(first_node),
              untrimmed.nodes.size() - static_cast<std::size_t>(untrimmed_first));
    for (std::size_t k = 0; k + static_cast<std::size_t>(first_node) < map.nodes.size(); ++k) {
      EXPECT_EQ(map.nodes[k + static_cast<std::size_t>(first_node)].local_pose,
                untrimmed.nodes[k + static_cast<std::size_t>(untrimmed_first)].local_pose)
          << k;
    }
    EXPECT_EQ(slam->stats().scans, reference->stats().scans);
    EXPECT_TRUE(slam->tied());
    if (!in_line) {
      EXPECT_GT(first.replayed_scans, 0);  // the scans that came while it trimmed
    }
  }
}

// One endless session (laps of the room, no map before), keep_current_session off: its older
// submaps are trimmed while it maps, so the graph stops growing with the laps; local SLAM goes on
// as without trimming (to 1e-9 m: the rebuilt submaps round differently), and every scan, those of
// removed nodes too, stays where an untrimmed run puts it.
TEST(MapTrimming, AnEndlessSessionTrimsItsOwnOlderSubmaps) {
  // The robot never leaves this small room: with the default gap its loops (every 10 nodes) would
  // make one cluster that never closes, and the submaps open clusters touch wait.
  LaserSlamParams sparse = roomSizedParams();
  sparse.loops.search_every_n_nodes = 150;
  sparse.rrr.rrr.cluster_gap = 4;
  constexpr int kScans = 640;  // six laps
  // The map's first session, and a session continuing threeLaps() from another odometry frame
  // (trimming the earlier session and, once tied, its own older submaps).
  for (const bool continued : {false, true}) {
    SCOPED_TRACE(continued ? "continuing a map" : "first session");
    const int first = continued ? 320 : 0;
    const double t0 = continued ? 1000.0 : 0.0;
    const core::Pose2 odom_frame = continued ? core::Pose2(3.0, -2.0, 0.7) : core::Pose2::Zero();
    auto start = [&] {
      return continued ? LaserSlam::fromMap(threeLaps(), sparse, "endless")
                       : std::make_unique<LaserSlam>(sparse, "endless");
    };
    const std::unique_ptr<LaserSlam> reference = start();
    drive(*reference, odom_frame, kScans, t0, first);
    const MapSnapshot untrimmed = reference->snapshot();
    const std::vector<core::Pose2> untrimmed_scans = reference->scanMapPoses();
    std::map<double, core::Pose2> local_at;  // the untrimmed run's local pose of each node
    for (const MapSnapshot::Node& node : untrimmed.nodes)
      local_at[node.timestamp] = node.local_pose;

    for (const bool in_line : {true, false}) {
      SCOPED_TRACE(in_line ? "in line" : "behind");
      OnlineTrimmer trimmer({trimParams(), 60, in_line});
      std::unique_ptr<LaserSlam> slam = start();
      int most_nodes = 0;
      for (int k = first; k < first + kScans; ++k) {
        RangeScan scan = castScan(room(), truthAt(k));
        scan.timestamp = t0 + 0.1 * k;
        const core::Pose2 odom = core::compose(odom_frame, truthAt(k));
        const std::optional<int> node = slam->addScan(scan, odom);
        std::unique_ptr<LaserSlam> trimmed = trimmer.afterScan(*slam, scan, odom, node);
        if (trimmed) slam = std::move(trimmed);
        most_nodes = std::max(most_nodes, slam->stats().nodes);
      }
      if (std::unique_ptr<LaserSlam> trimmed = trimmer.wait()) slam = std::move(trimmed);
      ASSERT_GT(trimmer.replaced(), 1);
      const MapSnapshot map = slam->snapshot();
      EXPECT_EQ(map.sessions.back().name, "endless");
      EXPECT_GT(map.lifelong.trimmed_submaps, 0);
      // The graph grows with the room, not with the laps.
      EXPECT_LT(map.nodes.size(), untrimmed.nodes.size() / 2);
      // Behind the map, how far the graph grows while a trim runs depends on the machine's load
      // (the scans come as fast as they are mapped: 663 of 960 nodes at the peak on a loaded
      // 2-core machine, against the in-line bound of 640): a looser bound there.
      EXPECT_LT(most_nodes,
                static_cast<int>(untrimmed.nodes.size()) * (in_line ? 2 : 17) / (in_line ? 3 : 20));
      EXPECT_GT(countKind(map, MapSnapshot::EdgeKind::kMarginal), 0);
      // The running session lost nodes of its own, and local SLAM went on as without trimming.
      const int session_nodes = static_cast<int>(map.nodes.size()) - map.sessions.back().first_node;
      EXPECT_LT(session_nodes, static_cast<int>(untrimmed.nodes.size()) -
                                   untrimmed.sessions.back().first_node - 60);
      for (const MapSnapshot::Node& node : map.nodes) {
        ASSERT_EQ(local_at.count(node.timestamp), 1u);
        EXPECT_LT((node.local_pose - local_at[node.timestamp]).norm(), 1e-9) << node.timestamp;
      }
      EXPECT_EQ(slam->stats().scans, reference->stats().scans);
      // The tie as it happened, before any trim of the session's own.
      ASSERT_EQ(slam->tie().has_value(), continued);
      if (continued) {
        EXPECT_TRUE(slam->tied());
        EXPECT_EQ(slam->tie()->session_node, reference->tie()->session_node);
        EXPECT_EQ(slam->tie()->timestamp, reference->tie()->timestamp);
      }
      // Every scan of the session, those of removed nodes too, where the untrimmed run and the
      // truth have it (the map's frame is the first session's odometry frame, the truth's).
      const std::vector<core::Pose2> scans = slam->scanMapPoses();
      const std::size_t mine = slam->sessionFirstScan();
      const std::size_t theirs = reference->sessionFirstScan();
      ASSERT_EQ(scans.size() - mine, untrimmed_scans.size() - theirs);
      const core::Pose2 motion = core::compose(untrimmed_scans.back(), core::inverse(scans.back()));
      for (std::size_t i = 0; mine + i < scans.size(); i += 7) {
        const core::Pose2& scan = scans[mine + i];
        const core::Pose2 expected = core::compose(motion, scan);
        EXPECT_LT((untrimmed_scans[theirs + i].head<2>() - expected.head<2>()).norm(), 0.1) << i;
        EXPECT_LT((truthAt(first + static_cast<int>(i)).head<2>() - scan.head<2>()).norm(), 0.15)
            << i;
      }
      const std::string path = ::testing::TempDir() + "endless_trimmed.rrrmap";
      writeMapFile(map, path);
      EXPECT_EQ(readMapFile(path).nodes.size(), map.nodes.size());
    }
  }
  // A running session's own submap is judged against its submaps of a later pass only, not
  // against those that follow it on the way (they would trim the trail the robot leaves, and with
  // it the submaps its next loops close on).
  const MapSnapshot& laps = threeLaps();  // 3 laps of about 100 nodes
  auto trimmedRunning = [&](int gap) {
    TrimParams p = trimParams();
    p.report_kl = false;
    p.revisit_gap_nodes = gap;
    return trimMap(laps, p, roomSizedParams().local.submap, NewestSession::kRunning).report;
  };
  const int any_newer = trimmedRunning(0).trimmed_submaps;
  const int next_lap = trimmedRunning(60).trimmed_submaps;
  EXPECT_GT(next_lap, 0);
  EXPECT_LT(next_lap, any_newer);
  EXPECT_EQ(trimmedRunning(1000).trimmed_submaps, 0);  // no pass came back that late
  EXPECT_EQ(trimMap(
                laps,
                [] {
                  TrimParams p = trimParams();
                  p.report_kl = false;
                  p.revisit_gap_nodes = 1000;
                  return p;
                }(),
                roomSizedParams().local.submap)
                .report.trimmed_submaps,
            any_newer);  // a finished session's submaps are judged against every newer one

  // With keep_current_session a first session has nothing to trim: no trim is even started.
  TrimParams keep = trimParams();
  keep.keep_current_session = true;
  OnlineTrimmer idle({keep, 60, true});
  LaserSlam slam(sparse, "endless");
  for (int k = 0; k < 300; ++k) {
    RangeScan scan = castScan(room(), truthAt(k));
    scan.timestamp = 0.1 * k;
    const std::optional<int> node = slam.addScan(scan, truthAt(k));
    EXPECT_EQ(idle.afterScan(slam, scan, truthAt(k), node), nullptr);
  }
  EXPECT_EQ(idle.finished(), 0);
}

// A trimmed map decided again at load keeps the loops it had: a robust ordering map that its
// rejected loops' large outliers bent (trusted chi2 1e5 where the map has 186) once made RRR
// test everything from there and reject all of them (test/data/README.md).
TEST(MapTrimming, ALoadedTrimmedMapKeepsItsLoops) {
  const MapSnapshot map = readMapFile("data/lifelong/aces_online_trimmed.rrrmap");
  ASSERT_GT(countKind(map, MapSnapshot::EdgeKind::kMarginal), 0);
  int accepted = 0;
  for (const auto& e : map.edges) {
    accepted +=
        e.kind == MapSnapshot::EdgeKind::kLoopCandidate && e.verdict == rrr::Verdict::kAccepted;
  }
  ASSERT_GT(accepted, 10);
  LaserSlamParams params;
  params.loops.threads = 1;
  const auto slam = LaserSlam::fromMap(map, params, "next");
  EXPECT_GE(slam->rrr().status().accepted, accepted);
  const std::vector<core::Pose2> poses = slam->rrr().mapPoses();
  const core::Pose2 motion = core::compose(poses[0], core::inverse(map.nodes[0].map_pose));
  for (std::size_t k = 0; k < map.nodes.size(); k += 10) {
    const core::Pose2 expected = core::compose(motion, map.nodes[k].map_pose);
    EXPECT_LT((poses[k].head<2>() - expected.head<2>()).norm(), 0.05) << k;
  }
}

TEST(MapTrimming, SubmapsWithPendingLoopsWaitAndRejectedLoopsGoWithTheirNodes) {
  MapSnapshot map = threeLaps();
  const TrimResult plain = trimMap(map, trimParams(), roomSizedParams().local.submap);
  ASSERT_FALSE(plain.report.trims.empty());
  // A pending loop touching a node of the first trimmed submap holds it back.
  const MapSnapshot::Submap span =
      map.submaps[static_cast<std::size_t>(plain.report.trims[0].submap)];
  bool marked = false;
  for (auto& e : map.edges) {
    if (e.kind != MapSnapshot::EdgeKind::kLoopCandidate) continue;
    if (e.from >= span.first_node && e.from <= span.last_node) {
      e.verdict = rrr::Verdict::kPending;
      marked = true;
      break;
    }
  }
  if (!marked) {  // no loop there: add a pending one
    MapSnapshot::Edge e;
    e.from = span.first_node;
    e.to = static_cast<int>(map.nodes.size()) - 1;
    e.kind = MapSnapshot::EdgeKind::kLoopCandidate;
    e.verdict = rrr::Verdict::kPending;
    e.measurement = core::between(map.nodes[e.from].map_pose, map.nodes[e.to].map_pose);
    map.edges.push_back(e);
  }
  const TrimResult waiting = trimMap(map, trimParams(), roomSizedParams().local.submap);
  EXPECT_GE(waiting.report.waiting_submaps, 1);
  for (const TrimRecord& t : waiting.report.trims)
    EXPECT_NE(t.submap, plain.report.trims[0].submap);
  int pending = 0;
  for (const auto& e : waiting.map.edges) {
    pending +=
        e.kind == MapSnapshot::EdgeKind::kLoopCandidate && e.verdict == rrr::Verdict::kPending;
  }
  EXPECT_EQ(pending, 1);  // never folded, never dropped

  // Rejected loops touching a removed node leave with it; the others stay.
  MapSnapshot with_rejected = threeLaps();
  auto rejected_loop = [&](int from, int to) {
    MapSnapshot::Edge e;
    e.from = from;
    e.to = to;
    e.kind = MapSnapshot::EdgeKind::kLoopCandidate;
    e.verdict = rrr::Verdict::kRejected;
    e.measurement = core::Pose2(1.0, 0.0, 0.0);
    with_rejected.edges.push_back(e);
  };
  const int last = static_cast<int>(with_rejected.nodes.size()) - 1;
  rejected_loop(span.first_node, span.first_node + 5);  // both ends leave
  rejected_loop(span.first_node, last);                 // one end leaves
  rejected_loop(last - 20, last);                       // both stay
  const TrimResult dropped = trimMap(with_rejected, trimParams(), roomSizedParams().local.submap);
  EXPECT_EQ(dropped.report.dropped_rejected_loops, 2);
  int rejected_out = 0;
  for (const auto& e : dropped.map.edges) rejected_out += e.verdict == rrr::Verdict::kRejected;
  EXPECT_EQ(rejected_out, 1);
}

// Sessions of the room, one per entry of `extras`: what stands in the room besides its walls
// that day. Each later session starts from the map of the ones before, tied to it.
MapSnapshot sessionsOf(const std::vector<std::vector<testing::Segment>>& extras) {
  LaserSlamParams params = roomSizedParams();
  params.loops.relocalization_confirm_distance_m = 3.0;  // a third of a lap: the sessions tie
  // What changed stands in space another session saw free: no free-space check of the matches.
  params.loops.relocalization_max_conflict = 1.0;
  std::unique_ptr<LaserSlam> slam;
  for (std::size_t day = 0; day < extras.size(); ++day) {
    const std::string name = "day" + std::to_string(day + 1);
    slam = slam ? LaserSlam::fromMap(slam->snapshot(), params, name)
                : std::make_unique<LaserSlam>(params, name);
    std::vector<testing::Segment> world = room();
    world.insert(world.end(), extras[day].begin(), extras[day].end());
    const core::Pose2 odom_frame(1.0 * day, -2.0 * day, 0.3 * day);
    for (int k = 0; k < 210; ++k) {
      RangeScan scan = castScan(world, truthAt(k));
      scan.timestamp = 1000.0 * static_cast<double>(day) + 0.1 * k;
      slam->addScan(scan, core::compose(odom_frame, truthAt(k)));
    }
    slam->finish();
  }
  return slam->snapshot();
}

// Whether every session after the first is tied to the map (accepted loops to earlier ones).
bool allTied(const MapSnapshot& map) {
  std::vector<char> tied(map.sessions.size(), 0);
  tied[0] = 1;
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind != MapSnapshot::EdgeKind::kLoopCandidate || e.verdict != rrr::Verdict::kAccepted) {
      continue;
    }
    const int a = map.nodes[static_cast<std::size_t>(e.from)].session;
    const int b = map.nodes[static_cast<std::size_t>(e.to)].session;
    if (a != b) tied[static_cast<std::size_t>(std::max(a, b))] = 1;
  }
  return std::all_of(tied.begin(), tied.end(), [](char t) { return t != 0; });
}

// The map as written, newest session per cell, at 0.05 m.
mrpt::maps::COccupancyGridMap2D renderedMap(const MapSnapshot& map) {
  MapInputs inputs = renderInputs(map);
  inputs.insertion = roomSizedParams().local.submap;
  inputs.render = MapRenderParams{};
  inputs.layering = MapLayering::kNewestSession;
  return renderOccupancyMap(inputs, 0.05);
}

double occupancy(const mrpt::maps::COccupancyGridMap2D& grid, double x, double y) {
  return 1.0 - grid.getPos(static_cast<float>(x), static_cast<float>(y));
}

// The most occupied cell along x in [x0, x1] at y: a wall at x0..x1, wherever the grid's cells
// put its rays' ends.
double wallAt(const mrpt::maps::COccupancyGridMap2D& grid, double x0, double x1, double y) {
  double most = 0.0;
  for (double x = x0; x <= x1; x += 0.02) most = std::max(most, occupancy(grid, x, y));
  return most;
}

// Day 2 alone saw a screen brought into the room; day 3's robot finds a panel in front of it and
// never sees the screen's cells again. Trimming takes days 1 and 2's submaps (day 3 covers
// them); the map still shows the screen, as the newest session that saw it did.
TEST(MapTrimming, TheCellsOfTrimmedSubmapsStayInTheMap) {
  const std::vector<testing::Segment> screen = {{{10.55, 1.5}, {10.55, 3.0}}};
  const std::vector<testing::Segment> panel = {{{10.25, 1.2}, {10.25, 3.3}}};
  const MapSnapshot map = sessionsOf({{}, screen, panel});
  ASSERT_TRUE(allTied(map));
  ASSERT_EQ(map.sessions.back().number, 2);
  // Untrimmed: day 2's view of the screen, the newest there is.
  EXPECT_GT(wallAt(renderedMap(map), 10.45, 10.6, 2.2), 0.65);
  TrimParams params = trimParams();
  params.keep_current_session = true;
  params.trim_overlap_ratio = 0.5;
  params.report_kl = false;
  const SubmapParams submap = roomSizedParams().local.submap;

  params.remember_trimmed_cells = false;
  const TrimResult plain = trimMap(map, params, submap);
  ASSERT_GT(plain.report.trimmed_submaps, 0);
  EXPECT_TRUE(plain.map.memory.empty());
  EXPECT_LT(wallAt(renderedMap(plain.map), 10.45, 10.6, 2.2), 0.65);  // it left with day 2

  params.remember_trimmed_cells = true;
  const TrimResult kept = trimMap(map, params, submap);
  EXPECT_EQ(kept.report.trimmed_submaps, plain.report.trimmed_submaps);
  EXPECT_EQ(kept.map.nodes.size(), plain.map.nodes.size());  // the graph is trimmed alike
  EXPECT_EQ(kept.map.edges.size(), plain.map.edges.size());
  EXPECT_GT(kept.report.remembered_patches, 0);
  EXPECT_EQ(kept.report.remembered_cells, rememberedCells(kept.map.memory));
  EXPECT_GT(kept.report.forgotten_cells, 0u);  // day 3 decides most of what days 1-2 saw
  const auto grid = renderedMap(kept.map);
  for (double y : {1.7, 2.2, 2.8}) EXPECT_GT(wallAt(grid, 10.45, 10.6, y), 0.65) << y;
  EXPECT_LT(occupancy(grid, 8.0, 2.2), 0.196);      // the floor as day 3 saw it
  EXPECT_GT(wallAt(grid, 10.15, 10.3, 2.2), 0.65);  // day 3's panel
  for (const RememberedCells& patch : kept.map.memory) {
    EXPECT_LE(patch.session, 1);  // days 1-2: day 3 is kept whole
    EXPECT_GE(patch.anchor_node, 0);
  }

  // Saved and loaded: the same memory; continued: a new session numbered after the others,
  // the memory carried on.
  // Days 1 and 2 left the graph whole: day 3, now the map's only session, keeps its number, so
  // the patches of days 1-2 stay older than it.
  EXPECT_EQ(kept.map.sessions.front().name, "day3");
  EXPECT_EQ(kept.map.sessions.front().number, 2);
  const std::string path = ::testing::TempDir() + "/remembered.rrrmap";
  writeMapFile(kept.map, path);
  const MapSnapshot read = readMapFile(path);
  ASSERT_EQ(read.memory.size(), kept.map.memory.size());
  for (std::size_t p = 0; p < read.memory.size(); ++p) {
    EXPECT_EQ(read.memory[p].session, kept.map.memory[p].session);
    EXPECT_EQ(read.memory[p].anchor_node, kept.map.memory[p].anchor_node);
    EXPECT_EQ(read.memory[p].origin, kept.map.memory[p].origin);
    EXPECT_EQ(*read.memory[p].cells, *kept.map.memory[p].cells);
  }
  for (std::size_t s = 0; s < read.sessions.size(); ++s) {
    EXPECT_EQ(read.sessions[s].number, kept.map.sessions[s].number);
  }
  auto next = LaserSlam::fromMap(read, roomSizedParams(), "day4");
  EXPECT_EQ(next->sessions().back().number, kept.map.sessions.back().number + 1);
  EXPECT_EQ(next->mapInputs().memory.size(), read.memory.size());
  EXPECT_EQ(rememberedCells(next->memory()), rememberedCells(read.memory));
}

TEST(MapTrimming, DeletionAndTheFreshAreaRuleAreTheAlternatives) {
  TrimParams params = trimParams();
  params.sparsification = Sparsification::kDelete;
  const TrimResult deleted = trimMap(threeLaps(), params, roomSizedParams().local.submap);
  EXPECT_EQ(deleted.report.marginalEdges(), 0);
  EXPECT_EQ(countKind(deleted.map, MapSnapshot::EdgeKind::kMarginal), 0);
  for (const TrimRecord& t : deleted.report.trims) EXPECT_EQ(t.kl_nats, t.kl_delete_nats);

  // Cartographer's rule: nothing is fresh enough to keep below a huge area, everything old goes;
  // with no area required nothing goes.
  const SubmapParams submap = roomSizedParams().local.submap;
  const TrimResult all = trimMap(threeLaps(), trimParams(), FreshAreaTrimming(1e6), submap);
  EXPECT_EQ(all.report.trimmed_submaps, static_cast<int>(threeLaps().submaps.size()) -
                                            trimParams().keep_recent_submaps -
                                            all.report.waiting_submaps);
  const TrimResult none = trimMap(threeLaps(), trimParams(), FreshAreaTrimming(0.0), submap);
  EXPECT_EQ(none.report.trimmed_submaps, 0);
  // The same rule chosen by the parameters (--trim-rule fresh-area, ROS trim_rule).
  TrimParams fresh = trimParams();
  fresh.trim_rule = TrimRule::kFreshArea;
  fresh.trim_min_fresh_area_m2 = 1e6;
  EXPECT_EQ(trimMap(threeLaps(), fresh, submap).report.trimmed_submaps, all.report.trimmed_submaps);
  fresh.trim_min_fresh_area_m2 = 0.0;
  EXPECT_EQ(trimMap(threeLaps(), fresh, submap).report.trimmed_submaps, 0);
  EXPECT_NE(trimmingStrategy(fresh)->describe().find("fresh area"), std::string::npos);
  EXPECT_NE(trimmingStrategy(trimParams())->describe().find("overlap ratio"), std::string::npos);
  fresh.trim_min_fresh_area_m2 = -1.0;
  EXPECT_THROW(trimMap(threeLaps(), fresh, submap), std::invalid_argument);
  EXPECT_EQ(parseTrimRule("fresh-area"), TrimRule::kFreshArea);
  EXPECT_EQ(toString(TrimRule::kOverlapRatio), "overlap-ratio");
  EXPECT_THROW(parseTrimRule("fresh"), std::invalid_argument);

  EXPECT_EQ(parseSparsification("dense"), Sparsification::kDense);
  EXPECT_EQ(parseSparsification("clt"), Sparsification::kClt);
  EXPECT_THROW(parseSparsification("tree"), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
