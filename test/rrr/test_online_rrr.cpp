// OnlineRrr, the core of the nodelet: streamed input decides like batch RRR, candidates may
// arrive before their nodes, bad input is refused without changing the graph, and a saved graph
// loads back to the same decisions.

#include <gtest/gtest.h>

#include <atomic>

#include <cmath>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/core/keyframe_selector.h"
#include "rrr_graphslam/rrr/decisions_io.h"
#include "rrr_graphslam/rrr/online_rrr.h"
#include "rrr_graphslam/rrr/rrr.h"

#include "streaming.h"
#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;
using NodeId = core::PoseGraph::NodeId;
using testing::Key;
using testing::keyOf;
using testing::stream;
using testing::withoutDuplicateCandidates;

OnlineRrrParams paramsWithGap(int gap) {
  OnlineRrrParams p;
  p.rrr.cluster_gap = gap;
  return p;
}

core::PoseGraph intelWithOutliers(int count, int group, unsigned seed) {
  return withoutDuplicateCandidates(
      testing::withOutliers(kData + "/intel.g2o.gz", count, group, seed).graph);
}

// Batch verdicts keyed by candidate ends and measurement.
std::map<Key, Verdict> batchVerdicts(const core::PoseGraph& g, int gap) {
  VerificationGraph graph(g, {});
  RrrParams params;
  params.cluster_gap = gap;
  std::vector<Verdict> verdicts;
  std::vector<int> clusters;
  runBatchRrr(graph, params, verdicts, clusters);
  std::map<Key, Verdict> out;
  for (int k = 0; k < graph.numCandidates(); ++k) {
    const auto& e = g.edge(graph.candidate(k).edge);
    out[keyOf(e.from, e.to, graph.candidate(k).measurement)] =
        verdicts[static_cast<std::size_t>(k)];
  }
  return out;
}

void expectBatchVerdicts(const OnlineRrr& online, const std::map<Key, Verdict>& batch) {
  ASSERT_EQ(static_cast<std::size_t>(online.numCandidates()), batch.size());
  for (int k = 0; k < online.numCandidates(); ++k) {
    const auto& c = online.candidate(k);
    const Key key = keyOf(online.nodeIds()[static_cast<std::size_t>(c.from)],
                          online.nodeIds()[static_cast<std::size_t>(c.to)], c.measurement);
    EXPECT_EQ(online.verdict(k), batch.at(key)) << "candidate " << k;
  }
}

class OnlineRrrStreaming : public ::testing::TestWithParam<bool> {};

TEST_P(OnlineRrrStreaming, DecidesLikeBatchAndReportsEveryChange) {
  const bool early = GetParam();
  const core::PoseGraph input = intelWithOutliers(60, 1, 3);
  const int gap = 5;
  const auto batch = batchVerdicts(input, gap);
  OnlineRrr online(paramsWithGap(gap));
  stream(input, online, early);
  expectBatchVerdicts(online, batch);

  // The changes, replayed, give the final verdicts; each candidate's first one is its arrival.
  std::vector<Verdict> replayed(static_cast<std::size_t>(online.numCandidates()));
  std::set<int> arrived;
  for (const DecisionChange& change : online.takeChanges()) {
    const auto k = static_cast<std::size_t>(change.candidate);
    if (arrived.insert(change.candidate).second) {
      EXPECT_EQ(change.verdict, Verdict::kPending);
      EXPECT_EQ(change.cluster, -1);
    } else {
      EXPECT_EQ(change.previous, replayed[k]);
      EXPECT_NE(change.verdict, change.previous);
      EXPECT_FALSE(change.reason.empty());
    }
    replayed[k] = change.verdict;
  }
  for (int k = 0; k < online.numCandidates(); ++k) {
    EXPECT_EQ(replayed[static_cast<std::size_t>(k)], online.verdict(k));
  }
  EXPECT_TRUE(online.takeChanges().empty());

  const OnlineRrrStatus s = online.status();
  EXPECT_EQ(s.nodes, static_cast<int>(input.numNodes()));
  EXPECT_EQ(s.accepted + s.rejected + s.pending, s.candidates);
  EXPECT_EQ(s.pending, 0);
  EXPECT_EQ(s.waiting_candidates, 0);
  EXPECT_EQ(s.open_clusters, 0);
}

INSTANTIATE_TEST_SUITE_P(CandidatesAtNewestOrOldestEnd, OnlineRrrStreaming,
                         ::testing::Values(false, true));

TEST(OnlineRrr, ARaisedCancelFlagCutsEveryOptimizationShort) {
  // What ~reset does to the graph it is about to throw away: every joint test stops at once, the
  // run still ends with every candidate decided, and the reasons say the optimizer was cancelled.
  const core::PoseGraph input = intelWithOutliers(60, 1, 3);
  const std::atomic<bool> cancel{true};
  OnlineRrr online(paramsWithGap(5));
  online.setCancelFlag(&cancel);
  stream(input, online, false);
  const OnlineRrrStatus s = online.status();
  EXPECT_EQ(s.pending, 0);
  EXPECT_EQ(s.accepted + s.rejected, s.candidates);
  int cancelled = 0;
  for (const DecisionChange& change : online.takeChanges()) {
    cancelled += change.reason.find("(optimizer: cancelled)") != std::string::npos;
  }
  EXPECT_GT(cancelled, 0);
}

// A robot driving a circle of `per_lap` nodes (odometry exact); loops join node k to k - per_lap.
core::Pose2 onCircle(int k, int per_lap) {
  const double a = 2.0 * M_PI * k / per_lap;
  return core::Pose2(10.0 * std::sin(a), 10.0 - 10.0 * std::cos(a), a);
}

TEST(OnlineRrr, ALoadedGraphDecidesItsNextClusterOnlineNotFromScratch) {
  // A graph whose replay passes a multiple of incremental_rebatch_every after its last cluster
  // closed: the decision from scratch is the loaded graph's own (finish), and the next cluster
  // after it is decided online, as if the graph had been built here. Two sessions (a rebatch
  // acts only with several): nodes 0-9, and the rest, tied to them by the cluster.
  constexpr int kPerLap = 60;
  OnlineRrrParams params = paramsWithGap(3);
  params.rrr.incremental_rebatch_every = 100;
  const Eigen::Matrix3d info = Eigen::Vector3d(1e4, 1e4, 1e5).asDiagonal();
  core::PoseGraph graph;
  for (int k = 0; k < 130; ++k) {
    graph.addNode(k, onCircle(k, kPerLap));
    if (k > 0 && k != 10) {
      graph.addEdge(k - 1, k, core::between(onCircle(k - 1, kPerLap), onCircle(k, kPerLap)), info,
                    core::EdgeKind::kOdometry);
    }
  }
  for (int k = 62; k < 66; ++k) {  // one cluster, closed long before node 100
    graph.addEdge(k - kPerLap, k,
                  core::between(onCircle(k - kPerLap, kPerLap), onCircle(k, kPerLap)), info,
                  core::EdgeKind::kLoopCandidate);
  }
  const auto loaded = OnlineRrr::fromPoseGraph(graph, params);
  loaded->takeChanges();
  ASSERT_EQ(loaded->verdict(0), Verdict::kAccepted);
  for (int k = 130; k < 140; ++k) {
    loaded->addOdometry(k - 1, k, core::between(onCircle(k - 1, kPerLap), onCircle(k, kPerLap)),
                        info);
  }
  loaded->addCandidate(131 - kPerLap, 131,
                       core::between(onCircle(131 - kPerLap, kPerLap), onCircle(131, kPerLap)),
                       info);
  for (int k = 140; k < 150; ++k) {  // the robot leaves it behind: the cluster closes
    loaded->addOdometry(k - 1, k, core::between(onCircle(k - 1, kPerLap), onCircle(k, kPerLap)),
                        info);
  }
  std::string reason;
  for (const DecisionChange& c : loaded->takeChanges()) {
    if (c.candidate == 4 && c.verdict != Verdict::kPending) reason = c.reason;
  }
  EXPECT_EQ(reason.rfind("online:", 0), 0u) << "decided by: " << reason;
  EXPECT_EQ(loaded->verdict(4), Verdict::kAccepted);
}

TEST(OnlineRrr, SavedGraphLoadsBackToTheSameDecisions) {
  const core::PoseGraph input = intelWithOutliers(40, 4, 5);
  OnlineRrr online(paramsWithGap(5));
  stream(input, online, false);
  const std::string path = ::testing::TempDir() + "online_saved.g2o";
  core::writePoseGraph(online.toPoseGraph(), path);
  core::GraphReadOptions options;
  options.allow_disconnected = true;
  const auto loaded =
      OnlineRrr::fromPoseGraph(core::readPoseGraph(path, options), paramsWithGap(5));
  const auto rows = online.decisionRows(), loaded_rows = loaded->decisionRows();
  ASSERT_EQ(rows.size(), loaded_rows.size());
  std::map<std::pair<NodeId, NodeId>, std::multiset<int>> a, b;
  for (const auto& r : rows) a[{r.from, r.to}].insert(static_cast<int>(r.verdict));
  for (const auto& r : loaded_rows) b[{r.from, r.to}].insert(static_cast<int>(r.verdict));
  EXPECT_EQ(a, b);
  // Every loaded candidate is reported, ending at its verdict.
  std::map<int, Verdict> last;
  for (const auto& change : loaded->takeChanges()) last[change.candidate] = change.verdict;
  ASSERT_EQ(static_cast<int>(last.size()), loaded->numCandidates());
  for (const auto& [k, v] : last) EXPECT_EQ(v, loaded->verdict(k));
  // The map frame: the optimized graph holds the odometry and the accepted loops.
  const core::PoseGraph optimized = online.optimizedPoseGraph();
  EXPECT_EQ(optimized.numNodes(), input.numNodes());
  EXPECT_EQ(static_cast<int>(optimized.numEdges()),
            static_cast<int>(input.numNodes()) - 1 + online.status().accepted);
}

TEST(OnlineRrr, ASavedLoopBetweenIdConsecutiveNodesOfTwoSessionsStaysALoop) {
  // Session A: nodes 0..9; session B: nodes 10..19 started elsewhere. Loops tie B's first node to
  // A's last one (ids 9 and 10: g2o alone would read that edge as odometry and merge the sessions).
  OnlineRrr online(paramsWithGap(3));
  const Eigen::Matrix3d info = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  const core::Pose2 step(1.0, 0.0, 0.0);
  online.startSession(0, core::Pose2::Zero());
  for (NodeId k = 1; k < 10; ++k) online.addOdometry(k - 1, k, step, info);
  online.startSession(10, core::Pose2(50.0, 50.0, 1.0));
  for (NodeId k = 11; k < 20; ++k) online.addOdometry(k - 1, k, step, info);
  // B continues A's line: node 10 one step past node 9.
  for (const auto& [from, to] : {std::pair<NodeId, NodeId>{9, 10}, {8, 10}, {9, 11}, {8, 11}}) {
    online.addCandidate(from, to, core::Pose2(static_cast<double>(to - from), 0.0, 0.0), info);
  }
  online.finish();
  ASSERT_EQ(online.status().sessions, 2);
  ASSERT_EQ(online.numCandidates(), 4);

  const std::string graph_path = ::testing::TempDir() + "two_sessions.g2o";
  const std::string decisions_path = ::testing::TempDir() + "two_sessions.decisions.tsv";
  core::writePoseGraph(online.toPoseGraph(), graph_path);
  writeDecisions(decisions_path, online.decisionRows());
  core::GraphReadOptions options;
  options.allow_disconnected = true;
  core::PoseGraph read = core::readPoseGraph(graph_path, options);
  // The ids alone make 9 -> 10 odometry: one session.
  EXPECT_EQ(OnlineRrr::fromPoseGraph(read, paramsWithGap(3))->status().sessions, 1);
  markCandidates(readDecisions(decisions_path), decisions_path, read);
  const auto loaded = OnlineRrr::fromPoseGraph(read, paramsWithGap(3));
  EXPECT_EQ(loaded->status().sessions, 2);
  EXPECT_EQ(loaded->numCandidates(), 4);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(loaded->verdict(k), online.verdict(k)) << k;

  // Rows that do not end the graph are refused, naming the decisions file and line.
  std::vector<DecisionRow> wrong = online.decisionRows();
  wrong.back().to = 15;
  try {
    markCandidates(wrong, decisions_path, read);
    FAIL() << "mismatched decisions accepted";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(decisions_path + ":5"), std::string::npos) << e.what();
  }
}

TEST(OnlineRrr, RefusesBadInputNamingTheFieldAndKeepsTheGraph) {
  OnlineRrr online(paramsWithGap(3));
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  const core::Pose2 step(1.0, 0.0, 0.0);
  for (NodeId n = 0; n < 6; ++n) online.addOdometry(n, n + 1, step, info);
  ASSERT_EQ(online.numNodes(), 7);
  online.addCandidate(6, 0, core::Pose2(-6.0, 0.0, 0.0), info);

  auto expect_refused = [&](auto call, const std::string& words) {
    const int nodes = online.numNodes(), candidates = online.numCandidates();
    try {
      call();
      ADD_FAILURE() << "accepted input that should fail with '" << words << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_EQ(online.numNodes(), nodes);
    EXPECT_EQ(online.numCandidates(), candidates);
  };
  const core::Pose2 nan(std::nan(""), 0.0, 0.0);
  Eigen::Matrix3d indefinite = info;
  indefinite(2, 2) = -1.0;
  Eigen::Matrix3d asymmetric = info;
  asymmetric(0, 1) = 0.5;
  expect_refused([&] { online.addOdometry(6, 7, nan, info); }, "measurement: x is not finite");
  expect_refused([&] { online.addOdometry(6, 7, step, indefinite); },
                 "information: the matrix is not positive definite");
  expect_refused([&] { online.addCandidate(6, 1, step, asymmetric); }, "not symmetric");
  expect_refused([&] { online.addOdometry(4, 5, step, info); }, "from_id 4 is not the newest");
  expect_refused([&] { online.addOdometry(6, 8, step, info); }, "to_id 8 does not follow");
  expect_refused([&] { online.addOdometry(8, 12, step, info); }, "to_id 12 does not follow");
  expect_refused([&] { online.addCandidate(6, 0, core::Pose2(-6.0, 0.0, 0.0), info); },
                 "duplicate candidate");
  expect_refused([&] { online.addCandidate(3, 4, step, info); }, "joined by odometry");
  expect_refused([&] { online.addCandidate(3, 3, step, info); }, "equals to_id");
  expect_refused([&] { online.startSession(5, core::Pose2::Zero()); }, "not newer");

  // A new session skips ids 7..9; a candidate waiting for id 8 is then dropped, and said so.
  EXPECT_EQ(online.addCandidate(8, 2, step, info), OnlineRrr::CandidateStatus::kWaiting);
  EXPECT_EQ(online.addCandidate(12, 2, core::Pose2(1, 2, 0), info),
            OnlineRrr::CandidateStatus::kWaiting);
  online.addOdometry(10, 11, step, info);
  const auto dropped = online.takeDroppedCandidates();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_NE(dropped[0].find("from_id 8 never arrived"), std::string::npos) << dropped[0];
  EXPECT_EQ(online.status().sessions, 2);
  EXPECT_EQ(online.status().waiting_candidates, 1);
  online.addOdometry(11, 12, step, info);
  EXPECT_EQ(online.status().waiting_candidates, 0);
  EXPECT_EQ(online.numCandidates(), 2);
  expect_refused([&] { online.addCandidate(8, 2, step, info); }, "from_id 8 is not a node");
}

TEST(OnlineRrr, MapToOdomFollowsTheNewestNode) {
  OnlineRrr online(paramsWithGap(3));
  EXPECT_TRUE(online.mapToOdom().isZero());
  const core::Pose2 start(2.0, -1.0, 0.3);
  online.startSession(0, start);
  online.addOdometry(0, 1, core::Pose2(1.0, 0.0, 0.1), Eigen::Matrix3d::Identity());
  // Without loops the map is the odometry frame.
  EXPECT_LT(online.mapToOdom().norm(), 1e-12);
  EXPECT_LT((online.odomPoses()[1] - core::compose(start, core::Pose2(1.0, 0.0, 0.1))).norm(),
            1e-12);
}

TEST(KeyframeSelector, NodesEveryMinTravelOrRotation) {
  core::KeyframeSelector selector({0.5, 0.4});
  EXPECT_TRUE(selector.accept(core::Pose2(0, 0, 0)));
  EXPECT_FALSE(selector.accept(core::Pose2(0.3, 0, 0)));
  EXPECT_FALSE(selector.accept(core::Pose2(0.49, 0.0, 0.39)));
  EXPECT_TRUE(selector.accept(core::Pose2(0.3, 0.4, 0)));  // 0.5 m from the last node
  EXPECT_FALSE(selector.accept(core::Pose2(0.3, 0.4, 0.2)));
  EXPECT_TRUE(selector.accept(core::Pose2(0.3, 0.4, -0.45)));  // turned 0.45 rad
  EXPECT_THROW(core::KeyframeSelector({0.0, 0.1}), std::invalid_argument);
  EXPECT_THROW(core::KeyframeSelector({0.1, std::nan("")}), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
