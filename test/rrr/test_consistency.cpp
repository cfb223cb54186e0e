// The intra-cluster test on the reduced graph against the whole-graph version, and the two
// consistency tests on mixed and false clusters.

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include <set>
#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/consistency.h"

#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

std::vector<std::vector<int>> clustersOf(const VerificationGraph& graph, int gap) {
  std::vector<CandidateEnds> ends;
  for (int k = 0; k < graph.numCandidates(); ++k)
    ends.emplace_back(graph.candidate(k).from, graph.candidate(k).to);
  return clusterCandidates(ends, gap);
}

TEST(Consistency, ReducedGraphMatchesWholeGraph) {
  const core::PoseGraph pose_graph = core::readPoseGraph(kData + "/intel.g2o.gz");
  VerificationGraph graph(pose_graph, {});
  const auto clusters = clustersOf(graph, 3);
  int compared = 0;
  for (std::size_t c = 0; c < clusters.size(); c += 4) {
    const LinkResiduals reduced = reducedGraphResiduals(graph, clusters[c], {});
    const LinkResiduals full = fullGraphResiduals(graph, clusters[c]);
    // First order in the odometry noise: equal up to a small fraction plus rounding.
    EXPECT_NEAR(reduced.total_chi2, full.total_chi2, 0.02 * full.total_chi2 + 1e-6)
        << "cluster " << c;
    const double threshold = core::chi2Quantile(0.95, 3 * static_cast<int>(clusters[c].size()));
    if (std::abs(full.total_chi2 - threshold) > 0.05 * threshold) {
      EXPECT_EQ(reduced.total_chi2 < threshold, full.total_chi2 < threshold) << "cluster " << c;
    }
    ++compared;
  }
  EXPECT_GT(compared, 20);
}

TEST(Consistency, LeaveOneOutIndexIsTheChi2DropOfRemovingTheLinks) {
  // The linearized statistic against the slow, obvious version: the whole graph optimized with
  // and without a cluster. Intel's loops, and one false link 1 m off a revisit's cluster.
  testing::LabelledGraph input{core::readPoseGraph(kData + "/intel.g2o.gz"), {}};
  VerificationGraph plain(input.graph, {});
  const auto clusters = clustersOf(plain, 3);
  const LoopCandidate& model = plain.candidate(clusters[clusters.size() / 2].front());
  const auto ids = plain.nodeIds();
  input.graph.addEdge(ids[static_cast<std::size_t>(model.from)],
                      ids[static_cast<std::size_t>(model.to)],
                      core::compose(model.measurement, core::Pose2(1.0, 0.0, 0.0)),
                      model.information, core::EdgeKind::kLoopCandidate);
  VerificationGraph graph(input.graph, {});
  const int false_link = graph.numCandidates() - 1;
  std::vector<int> all(static_cast<std::size_t>(graph.numCandidates()));
  std::iota(all.begin(), all.end(), 0);
  const double alpha = 0.95;
  auto chi2Without = [&](const std::vector<int>& removed, const std::vector<core::Pose2>& from) {
    std::vector<int> kept;
    for (int k : all) {
      if (std::find(removed.begin(), removed.end(), k) == removed.end()) kept.push_back(k);
    }
    graph.optimize(kept, core::startFrom(from));
    return graph.optimizer().chi2();
  };
  std::vector<std::vector<int>> tested = {{false_link}};
  for (std::size_t c = 0; c < clusters.size(); c += 7) tested.push_back(clusters[c]);
  for (const std::vector<int>& links : tested) {
    graph.optimize(all, core::startFrom(graph.initialPoses()));
    ASSERT_TRUE(graph.optimizer().covarianceAvailable());
    const std::vector<core::Pose2> solution = graph.optimizer().poses();
    const double with = graph.optimizer().chi2();
    const double index = leaveOneOutIndex(graph, links, solution, alpha);
    const double exact = (with - chi2Without(links, solution)) /
                         core::chi2Quantile(alpha, 3 * static_cast<int>(links.size()));
    EXPECT_NEAR(index, exact, 0.05 * exact + 0.01) << links.size() << " links from " << links[0];
  }
  // The false link stands out; it would not by its own residual at the joint solution.
  graph.optimize(all, core::startFrom(graph.initialPoses()));
  const std::vector<core::Pose2> solution = graph.optimizer().poses();
  EXPECT_GT(leaveOneOutIndex(graph, {false_link}, solution, alpha), 10.0);
  // Every set at once (in parallel from 16 sets): each index as alone, in the sets' order.
  ASSERT_GE(tested.size(), 16u);
  std::vector<const std::vector<int>*> sets;
  for (const std::vector<int>& links : tested) sets.push_back(&links);
  const std::vector<double> indices = leaveOneOutIndices(graph, sets, solution, alpha);
  ASSERT_EQ(indices.size(), tested.size());
  for (std::size_t i = 0; i < tested.size(); ++i)
    EXPECT_EQ(indices[i], leaveOneOutIndex(graph, tested[i], solution, alpha)) << i;
  EXPECT_GT(indices[0], 10.0);
  EXPECT_TRUE(leaveOneOutIndices(graph, {}, solution, alpha).empty());
}

TEST(Consistency, IntraDropsTheFalseLinkOfAMixedCluster) {
  // A revisit's cluster plus one link between the same places with a 2 m error.
  testing::LabelledGraph input{core::readPoseGraph(kData + "/intel.g2o.gz"), {}};
  VerificationGraph plain(input.graph, {});
  auto clusters = clustersOf(plain, 3);
  const auto biggest =
      *std::max_element(clusters.begin(), clusters.end(),
                        [](const auto& a, const auto& b) { return a.size() < b.size(); });
  ASSERT_GE(biggest.size(), 5u);
  const LoopCandidate& model = plain.candidate(biggest[2]);
  const auto ids = plain.nodeIds();
  input.graph.addEdge(ids[static_cast<std::size_t>(model.from)],
                      ids[static_cast<std::size_t>(model.to)],
                      model.measurement + core::Pose2(2.0, 0.0, 0.0), model.information,
                      core::EdgeKind::kLoopCandidate);
  VerificationGraph graph(input.graph, {});
  std::vector<int> mixed = biggest;
  const int wrong = graph.numCandidates() - 1;
  mixed.push_back(wrong);
  const IntraClusterResult r = intraClusterConsistency(
      mixed, 0.95,
      [&](const std::vector<int>& links) { return reducedGraphResiduals(graph, links, {}); });
  EXPECT_NE(std::find(r.dropped.begin(), r.dropped.end(), wrong), r.dropped.end());
  EXPECT_GE(r.kept.size(), biggest.size() - 1) << "the true links stay";
}

TEST(Consistency, InterRemovesAConsistentButFalseCluster) {
  // The links of one revisit all shifted by the same rigid error: consistent among themselves
  // (they only misplace one stretch of trajectory against another), so the cluster passes on its
  // own; jointly with the other revisits of the same place it must go.
  const core::PoseGraph original = core::readPoseGraph(kData + "/intel.g2o.gz");
  VerificationGraph plain(original, {});
  const auto clusters = clustersOf(plain, 3);
  // A revisit of 5 to 20 links.
  int biggest = -1;
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    const std::size_t n = clusters[c].size();
    if (n >= 5 && n <= 20 &&
        (biggest < 0 || n > clusters[static_cast<std::size_t>(biggest)].size())) {
      biggest = static_cast<int>(c);
    }
  }
  ASSERT_GE(biggest, 0);
  // Links implied by the optimized map with the revisiting stretch moved by W: exactly
  // consistent among themselves.
  core::Optimizer map = core::makeOptimizer(original);
  map.optimize();
  const core::Pose2 W(1.0, 0.5, 0.15);
  std::set<std::size_t> shifted;
  for (int k : clusters[static_cast<std::size_t>(biggest)]) shifted.insert(plain.candidate(k).edge);
  core::PoseGraph corrupted;
  for (auto id : original.nodeIds()) corrupted.addNode(id, original.pose(id));
  for (std::size_t k = 0; k < original.numEdges(); ++k) {
    core::Pose2 z = original.measurement(k);
    if (shifted.count(k)) {
      const auto from = static_cast<std::size_t>(plain.optimizer().from(static_cast<int>(k)));
      const auto to = static_cast<std::size_t>(plain.optimizer().to(static_cast<int>(k)));
      z = core::between(map.poses()[from], core::compose(W, map.poses()[to]));
    }
    corrupted.addEdge(original.edge(k).from, original.edge(k).to, z, original.information(k),
                      original.edge(k).kind);
  }
  VerificationGraph graph(corrupted, {});
  const auto& false_links = clusters[static_cast<std::size_t>(biggest)];
  const IntraClusterResult alone = intraClusterConsistency(
      false_links, 0.95,
      [&](const std::vector<int>& links) { return reducedGraphResiduals(graph, links, {}); });
  EXPECT_EQ(alone.kept.size(), false_links.size()) << "consistent among themselves";
  std::vector<int> all(clusters.size());
  std::iota(all.begin(), all.end(), 0);
  const InterClusterResult inter =
      interClusterConsistency(graph, clusters, all, graph.initialPoses(), 0.95, 1.0);
  EXPECT_NE(std::find(inter.removed.begin(), inter.removed.end(), biggest), inter.removed.end());
  EXPECT_LE(inter.removed.size(), 3u) << "true clusters stay";
}

TEST(Consistency, RobustMapWithoutGraduationKeepsTheBasinOfItsStart) {
  // A building seen again and again: many groups of false loops that share one wrong rigid
  // offset (an aliased corridor), each consistent with itself and with odometry on both sides,
  // beside the true loops. Graduated DCS begins with the least squares of every link, which the
  // aliased groups bend; from a start that is already the map, DCS without graduation stays in
  // its basin (what Rrr's robust ordering uses the last decision's map for).
  const core::PoseGraph original = core::readPoseGraph(kData + "/intel.g2o.gz");
  core::Optimizer clean = core::makeOptimizer(original);
  clean.optimize();
  const std::vector<core::Pose2> truth = clean.poses();
  int true_links = 0;
  for (std::size_t k = 0; k < original.numEdges(); ++k)
    true_links += original.edge(k).kind == core::EdgeKind::kLoopCandidate;
  const core::Pose2 offset(3.0, -2.0, M_PI);  // the alias: the same place turned around
  const testing::LabelledGraph aliased =
      testing::withAliasedGroups(original, truth, offset, true_links / 2, 20,
                                 Eigen::Vector3d(400.0, 400.0, 2500.0).asDiagonal(), 7);
  VerificationGraph graph(aliased.graph, {});
  std::vector<int> links(static_cast<std::size_t>(graph.numCandidates()));
  std::iota(links.begin(), links.end(), 0);
  // How many true loops agree with a map, and how far it is from the truth.
  const double gate = core::chi2Quantile(0.95, 3);
  auto agreeing_true_links = [&](const std::vector<core::Pose2>& map) {
    graph.optimizer().setPoses(map);
    int agreeing = 0;
    for (int k = 0; k < true_links; ++k)
      agreeing += graph.optimizer().constraintChi2(graph.candidate(k).constraint) < gate;
    return agreeing;
  };
  auto largest_shift = [&](const std::vector<core::Pose2>& map) {
    double shift = 0.0;
    for (std::size_t n = 0; n < map.size(); ++n)
      shift = std::max(shift, (map[n].head<2>() - truth[n].head<2>()).norm());
    return shift;
  };
  int optimizations = 0;
  const std::vector<core::Pose2> graduated = robustMap(graph, links, truth, 1.0, optimizations);
  const std::vector<core::Pose2> from_start =
      robustMap(graph, links, truth, 1.0, optimizations, {}, /*graduated=*/false);
  const int agreeing_at_truth = agreeing_true_links(truth);
  // Precondition, not the property tested: the input is hard, least squares of every link leaves
  // the truth's basin (if graduated DCS ever keeps it, choose a harder input).
  ASSERT_GT(largest_shift(graduated), 1.0) << "precondition: graduated DCS leaves the basin";
  ASSERT_LT(agreeing_true_links(graduated), agreeing_at_truth * 9 / 10) << "precondition";
  // Without graduation the start's basin is kept.
  EXPECT_LT(largest_shift(from_start), 0.2);
  EXPECT_GE(agreeing_true_links(from_start), agreeing_at_truth * 99 / 100);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
