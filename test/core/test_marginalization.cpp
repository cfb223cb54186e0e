// Node marginalization: the sparse (CHOLMOD) Schur complement against the dense one, the dense
// one against the brute-force marginal of the whole graph, its chi2 against the removed
// constraints re-optimized over the removed nodes, its gauge, and bad input.

#include "rrr_graphslam/core/marginalization.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "marginalization_test_graphs.h"
#include "rrr_graphslam/core/gaussian_kl.h"
#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {
namespace {

using test_graphs::expectInvalidArgumentMentioning;
using test_graphs::posesOf;
using test_graphs::randomChainWithLoops;
using test_graphs::run;

// Random graphs of 20-60 nodes, a run of 5-15 consecutive nodes removed.
struct Case {
  PoseGraph graph;
  std::vector<NodeId> removed;
};

Case randomCase(unsigned seed) {
  std::mt19937 rng(seed);
  const int n = std::uniform_int_distribution<int>(20, 60)(rng);
  const int count = std::uniform_int_distribution<int>(5, 15)(rng);
  const int first = std::uniform_int_distribution<int>(0, n - count)(rng);
  return {randomChainWithLoops(n, seed, n / 4), run(first, count)};
}

TEST(Marginalization, SparseSchurComplementMatchesDense) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Case c = randomCase(seed);
    const std::vector<PoseConstraint> constraints = constraintsOf(c.graph);
    const Marginal sparse = marginalizeNodes(constraints, posesOf(c.graph), c.removed);
    const Marginal dense = marginalizeNodesDense(constraints, posesOf(c.graph), c.removed);
    ASSERT_EQ(sparse.blanket, dense.blanket) << seed;
    EXPECT_GE(sparse.blanket.size(), 2u) << seed;
    EXPECT_EQ(sparse.removed_nodes, c.removed) << seed;
    EXPECT_EQ(sparse.removed_constraints, dense.removed_constraints) << seed;
    const double scale = dense.information.cwiseAbs().maxCoeff();
    EXPECT_LT((sparse.information - dense.information).cwiseAbs().maxCoeff(), 1e-9 * scale) << seed;
    EXPECT_LT((sparse.gradient - dense.gradient).cwiseAbs().maxCoeff(),
              1e-9 * dense.gradient.cwiseAbs().maxCoeff())
        << seed;
    EXPECT_NEAR(sparse.chi2_at_linearization, dense.chi2_at_linearization,
                1e-9 * dense.chi2_at_linearization)
        << seed;
    EXPECT_GT(dense.gradient.norm(), 0.0) << "the graph is away from its minimum";
    // Every removed constraint touches M, every kept one does not.
    for (std::size_t k = 0; k < constraints.size(); ++k) {
      const bool touches =
          std::binary_search(c.removed.begin(), c.removed.end(), constraints[k].from) ||
          std::binary_search(c.removed.begin(), c.removed.end(), constraints[k].to);
      EXPECT_EQ(touches, std::binary_search(sparse.removed_constraints.begin(),
                                            sparse.removed_constraints.end(), k));
    }
  }
}

// The Gaussian over every node except `anchor` (held at its linearization point) and M of a
// quadratic model over `nodes`, marginalized onto `kept` (ids, in order) by a dense inverse.
struct Gaussian {
  Eigen::VectorXd mean;
  Eigen::MatrixXd information;
};

Gaussian bruteForceMarginal(const QuadraticModel& model, const std::vector<NodeId>& nodes,
                            NodeId anchor, const std::vector<NodeId>& kept) {
  std::vector<Eigen::Index> free, wanted;
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (nodes[k] == anchor) continue;
    for (int r = 0; r < 3; ++r) free.push_back(static_cast<Eigen::Index>(3 * k) + r);
  }
  const Eigen::MatrixXd H = model.information(free, free);
  const Eigen::MatrixXd covariance = H.inverse();
  const Eigen::VectorXd mean = -covariance * model.gradient(free);
  for (NodeId id : kept) {
    const auto at = std::find(nodes.begin(), nodes.end(), id) - nodes.begin();
    const auto position = std::find(free.begin(), free.end(), 3 * at) - free.begin();
    for (int r = 0; r < 3; ++r) wanted.push_back(position + r);
  }
  return {mean(wanted), Eigen::MatrixXd(covariance(wanted, wanted)).inverse()};
}

// The whole graph's linearized distribution over the blanket (one blanket node anchored) is the
// same whether M is in the graph or replaced by its marginal: KL < 1e-6, means included.
TEST(Marginalization, DenseMarginalIsTheBruteForceMarginalOfTheWholeGraph) {
  for (unsigned seed = 21; seed <= 30; ++seed) {
    const Case c = randomCase(seed);
    const std::vector<PoseConstraint> constraints = constraintsOf(c.graph);
    const Marginal marginal = marginalizeNodesDense(constraints, posesOf(c.graph), c.removed);
    const NodeId anchor = marginal.blanket.front();
    const std::vector<NodeId> compared(marginal.blanket.begin() + 1, marginal.blanket.end());

    const std::vector<NodeId> all = c.graph.nodeIds();
    std::vector<Pose2> all_poses;
    for (NodeId id : all) all_poses.push_back(c.graph.pose(id));
    const Gaussian full = bruteForceMarginal(linearizeConstraints(constraints, all, all_poses), all,
                                             anchor, compared);

    // The graph without M, with the marginal in its place.
    std::vector<NodeId> kept;
    std::vector<Pose2> kept_poses;
    for (NodeId id : all) {
      if (std::binary_search(c.removed.begin(), c.removed.end(), id)) continue;
      kept.push_back(id);
      kept_poses.push_back(c.graph.pose(id));
    }
    std::vector<PoseConstraint> rest;
    for (std::size_t k = 0; k < constraints.size(); ++k) {
      if (!std::binary_search(marginal.removed_constraints.begin(),
                              marginal.removed_constraints.end(), k)) {
        rest.push_back(constraints[k]);
      }
    }
    QuadraticModel replaced = linearizeConstraints(rest, kept, kept_poses);
    QuadraticModel weakened = replaced;
    for (std::size_t i = 0; i < marginal.blanket.size(); ++i) {
      const auto a = 3 * (std::find(kept.begin(), kept.end(), marginal.blanket[i]) - kept.begin());
      replaced.gradient.segment<3>(a) +=
          marginal.gradient.segment<3>(3 * static_cast<Eigen::Index>(i));
      for (std::size_t j = 0; j < marginal.blanket.size(); ++j) {
        const auto b =
            3 * (std::find(kept.begin(), kept.end(), marginal.blanket[j]) - kept.begin());
        const Eigen::Matrix3d block = marginal.information.block<3, 3>(
            3 * static_cast<Eigen::Index>(i), 3 * static_cast<Eigen::Index>(j));
        replaced.information.block<3, 3>(a, b) += block;
        weakened.information.block<3, 3>(a, b) += 0.9 * block;
      }
    }
    const Gaussian reduced = bruteForceMarginal(replaced, kept, anchor, compared);
    EXPECT_GT(full.mean.norm(), 1e-3) << "the means take part in the comparison";
    EXPECT_LT(gaussianKl(full.mean, full.information, reduced.mean, reduced.information), 1e-6)
        << seed;
    // The comparison can tell: 10% less of the marginal's information is far off.
    const Gaussian weaker = bruteForceMarginal(weakened, kept, anchor, compared);
    EXPECT_GT(gaussianKl(full.mean, full.information, weaker.mean, weaker.information), 1e-2)
        << seed;
  }
}

// With every constraint satisfied (c = 0, g = 0), the removed constraints' chi2 re-optimized
// over M by the optimizer, with the blanket moved by a small step, is the marginal's quadratic
// form to second order: the error convention and Jacobians are the optimizer's.
TEST(Marginalization, ChiSquareIsTheRemovedConstraintsReoptimizedOverM) {
  const PoseGraph graph = randomChainWithLoops(30, 7, 8, 0.0);
  const std::vector<NodeId> removed = run(10, 8);
  const Marginal marginal = marginalizeNodes(graph, removed);
  EXPECT_NEAR(marginal.chi2_at_linearization, 0.0, 1e-18);
  EXPECT_LT(marginal.gradient.norm(), 1e-9);

  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::vector<Pose2> moved = marginal.linearization_point;
  for (Pose2& p : moved) p += Pose2(noise(rng), noise(rng), noise(rng));

  // The removed constraints alone, the blanket fixed at `moved`, M free from its poses.
  Optimizer optimizer;
  std::map<NodeId, int> index;
  for (NodeId id : removed) index[id] = optimizer.addNode(graph.pose(id));
  for (std::size_t k = 0; k < marginal.blanket.size(); ++k) {
    index[marginal.blanket[k]] = optimizer.addNode(moved[k]);
    optimizer.setFixed(index[marginal.blanket[k]], true);
  }
  const std::vector<PoseConstraint> constraints = constraintsOf(graph);
  for (std::size_t k : marginal.removed_constraints) {
    const PoseConstraint& c = constraints[k];
    optimizer.addConstraint(index[c.from], index[c.to], c.measurement, c.information);
  }
  ASSERT_TRUE(optimizer.optimize().converged());
  const double expected = marginalChi2(marginal, moved);
  EXPECT_GT(expected, 1e-3);
  EXPECT_NEAR(optimizer.chi2(), expected, 1e-3 * expected);
  EXPECT_NEAR(marginalChi2(marginal, marginal.linearization_point), 0.0, 1e-18);
}

// Infinitesimal rigid motion (v_x, v_y, omega) of poses: dx_i = (v_x - omega y_i, v_y + omega
// x_i, omega).
Eigen::VectorXd rigidMotion(const std::vector<Pose2>& poses, const Eigen::Vector3d& v) {
  Eigen::VectorXd dx(static_cast<Eigen::Index>(3 * poses.size()));
  for (std::size_t k = 0; k < poses.size(); ++k) {
    dx.segment<3>(static_cast<Eigen::Index>(3 * k)) << v.x() - v.z() * poses[k].y(),
        v.y() + v.z() * poses[k].x(), v.z();
  }
  return dx;
}

int numericalRank(const Eigen::MatrixXd& information) {
  const Eigen::VectorXd eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(information).eigenvalues();
  return static_cast<int>((eigenvalues.array() > 1e-9 * eigenvalues.maxCoeff()).count());
}

TEST(Marginalization, GaugeIsARigidMotionPerPieceOfTheBlanket) {
  const PoseGraph graph = randomChainWithLoops(40, 11, 10);
  const Marginal marginal = marginalizeNodes(graph, run(12, 10));
  const auto n = static_cast<int>(marginal.blanket.size());
  ASSERT_GE(n, 3);
  EXPECT_EQ(numericalRank(marginal.information), 3 * (n - 1));
  for (const Eigen::Vector3d v :
       {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()}) {
    const Eigen::VectorXd dx = rigidMotion(marginal.linearization_point, v);
    EXPECT_LT((marginal.information * dx).norm(), 1e-9 * marginal.information.norm() * dx.norm());
    EXPECT_LT(std::abs(marginal.gradient.dot(dx)), 1e-9 * marginal.gradient.norm() * dx.norm());
  }

  // Two runs of a chain without loop closures: two pieces {4, 9} and {19, 24}, each with its
  // own gauge, and exactly zero blocks between them.
  const PoseGraph chain = randomChainWithLoops(30, 12, 0);
  std::vector<NodeId> removed = run(5, 4);
  for (NodeId id : run(20, 4)) removed.push_back(id);
  for (const Marginal& pieces :
       {marginalizeNodes(chain, removed),
        marginalizeNodesDense(constraintsOf(chain), posesOf(chain), removed)}) {
    ASSERT_EQ(pieces.blanket, (std::vector<NodeId>{4, 9, 19, 24}));
    EXPECT_EQ(numericalRank(pieces.information), 6);
    EXPECT_TRUE(pieces.information.block(0, 6, 6, 6).isZero(0.0));
    EXPECT_TRUE(pieces.information.block(6, 0, 6, 6).isZero(0.0));
    EXPECT_FALSE(pieces.information.block(0, 3, 3, 3).isZero(0.0));
  }
}

TEST(Marginalization, PoseGraphOverloadKeysConstraintsOnEdgeIndices) {
  const Case c = randomCase(40);
  const Marginal from_graph = marginalizeNodes(c.graph, c.removed);
  const Marginal from_list = marginalizeNodes(constraintsOf(c.graph), posesOf(c.graph), c.removed);
  EXPECT_EQ(from_graph.removed_constraints, from_list.removed_constraints);
  EXPECT_EQ(from_graph.blanket, from_list.blanket);
  EXPECT_EQ(from_graph.information, from_list.information);
  for (std::size_t k : from_graph.removed_constraints) {
    const PoseGraph::Edge& e = c.graph.edge(k);
    EXPECT_TRUE(std::binary_search(c.removed.begin(), c.removed.end(), e.from) ||
                std::binary_search(c.removed.begin(), c.removed.end(), e.to));
  }
}

TEST(Marginalization, BadInputThrowsNamingTheProblem) {
  const PoseGraph graph = randomChainWithLoops(20, 13, 0);
  const std::vector<PoseConstraint> constraints = constraintsOf(graph);
  const std::map<NodeId, Pose2> poses = posesOf(graph);
  using Marginalize = Marginal (*)(const std::vector<PoseConstraint>&,
                                   const std::map<NodeId, Pose2>&, const std::vector<NodeId>&);
  for (const Marginalize marginalize : {static_cast<Marginalize>(&marginalizeNodes),
                                        static_cast<Marginalize>(&marginalizeNodesDense)}) {
    auto call = [&](const std::vector<PoseConstraint>& c, const std::map<NodeId, Pose2>& p,
                    const std::vector<NodeId>& m) { return [=] { marginalize(c, p, m); }; };
    expectInvalidArgumentMentioning(call(constraints, poses, {}), "no nodes");
    expectInvalidArgumentMentioning(call(constraints, poses, {5, 6, 5}), "node 5 is listed twice");
    expectInvalidArgumentMentioning(call(constraints, poses, {5, 77}), "node 77 is unknown");

    std::map<NodeId, Pose2> nan_pose = poses;
    nan_pose[4].y() = std::numeric_limits<double>::quiet_NaN();  // a blanket node
    expectInvalidArgumentMentioning(call(constraints, nan_pose, {5, 6}), "node 4: pose y");
    nan_pose = poses;
    nan_pose[6].z() = std::numeric_limits<double>::infinity();  // a removed node
    expectInvalidArgumentMentioning(call(constraints, nan_pose, {5, 6}), "node 6: pose theta");

    std::vector<PoseConstraint> bad = constraints;
    bad[5].information(1, 1) = -1.0;  // constraint 5 joins 5 -> 6
    expectInvalidArgumentMentioning(call(bad, poses, {6}), "constraint 5 (5 -> 6): information");
    bad = constraints;
    bad[5].measurement.x() = std::numeric_limits<double>::quiet_NaN();
    expectInvalidArgumentMentioning(call(bad, poses, {6}), "constraint 5 (5 -> 6): measurement");
    bad = constraints;
    bad[5].to = 5;
    expectInvalidArgumentMentioning(call(bad, poses, {5}), "constraint 5 (5 -> 5) is a self-loop");
    std::map<NodeId, Pose2> missing = poses;
    missing.erase(7);
    expectInvalidArgumentMentioning(call(constraints, missing, {6}), "joins node 7");

    // A removed piece with no constraint to a kept node: an isolated node, and the whole chain.
    std::map<NodeId, Pose2> with_isolated = poses;
    with_isolated[100] = Pose2(1.0, 2.0, 0.3);
    expectInvalidArgumentMentioning(call(constraints, with_isolated, {6, 100}),
                                    "node 100 (with the removed nodes connected to it) has no "
                                    "constraint to a kept node");
    expectInvalidArgumentMentioning(call(constraints, poses, run(0, 20)), "node 0 (with");
  }
  // Constraints that do not touch M are not looked at.
  std::vector<PoseConstraint> elsewhere = constraints;
  elsewhere[15].information(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NO_THROW(marginalizeNodes(elsewhere, poses, {3}));
}

}  // namespace
}  // namespace rrr_graphslam::core
