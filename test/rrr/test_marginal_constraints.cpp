// RRR on a graph that lifelong trimming thinned: a stretch of nodes marginalized into a Chow-Liu
// tree of marginal constraints (trusted, always active) leaves the odometry chain with a gap.
// RRR still decides the surviving candidates as it did on the whole graph, the pieces of the
// chain move as one, and the marginal constraints survive every round trip.

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "rrr_graphslam/core/chow_liu.h"
#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/marginalization.h"
#include "rrr_graphslam/rrr/incremental_rrr.h"
#include "rrr_graphslam/rrr/online_rrr.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

struct Thinned {
  core::PoseGraph graph;
  std::vector<bool> candidate_is_true;
  std::vector<Verdict> whole_verdict;  // per candidate of `graph`: its verdict on the whole graph
  int marginal_edges = 0;
};

// Intel with 100 false loops; nodes [first, first + count) are marginalized out of the trusted
// graph (odometry + the loops batch RRR accepts on the whole graph) at its optimum.
Thinned thinnedIntel(core::PoseGraph::NodeId first, int count) {
  const testing::LabelledGraph input = testing::withOutliers(kData + "/intel.g2o.gz", 100, 1, 11);
  RrrParams params;
  VerificationGraph whole(input.graph, params.optimizer);
  std::vector<Verdict> verdicts;
  std::vector<int> cluster_of;
  runBatchRrr(whole, params, verdicts, cluster_of);

  core::PoseGraph trusted;
  for (auto id : input.graph.nodeIds()) trusted.addNode(id, input.graph.pose(id));
  int candidate = 0;
  std::map<std::size_t, int> candidate_of_edge;
  for (std::size_t e = 0; e < input.graph.numEdges(); ++e) {
    const auto& edge = input.graph.edge(e);
    if (edge.kind == core::EdgeKind::kLoopCandidate) {
      candidate_of_edge[e] = candidate;
      if (verdicts[static_cast<std::size_t>(candidate++)] != Verdict::kAccepted) continue;
    }
    trusted.addEdge(edge.from, edge.to, input.graph.measurement(e), input.graph.information(e),
                    core::EdgeKind::kOdometry);
  }
  core::Optimizer optimizer = core::makeOptimizer(trusted);
  optimizer.optimize();
  core::copyPosesToGraph(optimizer, trusted);
  std::vector<core::NodeId> removed;
  for (int k = 0; k < count; ++k) removed.push_back(first + static_cast<core::NodeId>(k));
  const core::Marginal marginal = core::marginalizeNodes(trusted, removed);
  const std::set<core::NodeId> gone(removed.begin(), removed.end());

  Thinned out;
  for (auto id : input.graph.nodeIds()) {
    if (!gone.count(id)) out.graph.addNode(id, input.graph.pose(id));  // odometry-frame start
  }
  for (std::size_t e = 0; e < input.graph.numEdges(); ++e) {
    const auto& edge = input.graph.edge(e);
    if (gone.count(edge.from) || gone.count(edge.to)) continue;
    out.graph.addEdge(edge.from, edge.to, input.graph.measurement(e), input.graph.information(e),
                      edge.kind);
    if (edge.kind == core::EdgeKind::kLoopCandidate) {
      const int k = candidate_of_edge.at(e);
      out.candidate_is_true.push_back(input.candidate_is_true[static_cast<std::size_t>(k)]);
      out.whole_verdict.push_back(verdicts[static_cast<std::size_t>(k)]);
    }
  }
  for (const core::ChowLiuEdge& c : core::chowLiuTree(marginal)) {
    out.graph.addEdge(c.constraint.from, c.constraint.to, c.constraint.measurement,
                      c.constraint.information, core::EdgeKind::kMarginal);
    ++out.marginal_edges;
  }
  return out;
}

TEST(MarginalConstraints, RrrDecidesAThinnedGraphAsTheWholeOne) {
  const Thinned thinned = thinnedIntel(300, 40);
  ASSERT_GT(thinned.marginal_edges, 1);
  RrrParams params;
  VerificationGraph graph(thinned.graph, params.optimizer);
  // The chain has a gap where the nodes left; the marginal constraints hold its two pieces as one.
  EXPECT_EQ(graph.chain().numSessions(), 2);
  const std::vector<int> component = graph.trustedComponents();
  EXPECT_EQ(*std::max_element(component.begin(), component.end()), 0);
  EXPECT_EQ(static_cast<int>(graph.marginalLinks().size()), thinned.marginal_edges);

  for (bool incremental : {false, true}) {
    VerificationGraph g(thinned.graph, params.optimizer);
    std::vector<Verdict> verdicts;
    std::vector<int> cluster_of;
    if (incremental) {
      RrrParams online = params;
      online.cluster_gap = 10;
      runIncrementalRrr(g, online, verdicts, cluster_of);
    } else {
      runBatchRrr(g, params, verdicts, cluster_of);
    }
    int false_accepted = 0, differ = 0, true_accepted = 0;
    for (std::size_t k = 0; k < verdicts.size(); ++k) {
      const bool accepted = verdicts[k] == Verdict::kAccepted;
      if (accepted && !thinned.candidate_is_true[k]) ++false_accepted;
      true_accepted += accepted && thinned.candidate_is_true[k];
      differ += accepted != (thinned.whole_verdict[k] == Verdict::kAccepted);
    }
    EXPECT_EQ(false_accepted, 0) << (incremental ? "incremental" : "batch");
    EXPECT_GT(true_accepted, 700) << (incremental ? "incremental" : "batch");
    EXPECT_LE(differ, static_cast<int>(verdicts.size()) / 100)
        << (incremental ? "incremental" : "batch");
  }
}

TEST(MarginalConstraints, OnlineRrrKeepsThemThroughItsRoundTrips) {
  const Thinned thinned = thinnedIntel(500, 25);
  const auto online = OnlineRrr::fromPoseGraph(thinned.graph, OnlineRrrParams{});
  EXPECT_EQ(online->status().marginal_edges, thinned.marginal_edges);
  for (const core::PoseGraph& g :
       {online->toPoseGraph(), online->mapPoseGraph(), online->optimizedPoseGraph()}) {
    int marginal = 0;
    for (const auto& e : g.edges()) marginal += e.kind == core::EdgeKind::kMarginal;
    EXPECT_EQ(marginal, thinned.marginal_edges);
  }
  // Added one by one: checked like any constraint, and trusted at once.
  OnlineRrr growing;
  growing.addOdometry(0, 1, core::Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  growing.addOdometry(1, 2, core::Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  EXPECT_THROW(growing.addMarginal(0, 7, core::Pose2(2.0, 0.0, 0.0), Eigen::Matrix3d::Identity()),
               std::invalid_argument);
  EXPECT_THROW(growing.addMarginal(0, 2, core::Pose2(2.0, 0.0, 0.0), Eigen::Matrix3d::Zero()),
               std::invalid_argument);
  EXPECT_THROW(growing.addMarginal(2, 2, core::Pose2(0.0, 0.0, 0.0), Eigen::Matrix3d::Identity()),
               std::invalid_argument);
  growing.addMarginal(0, 2, core::Pose2(2.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  EXPECT_EQ(growing.status().marginal_edges, 1);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
