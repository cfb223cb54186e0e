// The dense replacement of marginalized nodes (dense_factor.h): it gives the marginal back at its
// linearization point, it is invariant to a rigid motion of the graph, a graph that keeps it is
// optimized to the full graph's minimum, marginalizing again through it equals marginalizing
// everything at once, and the optimizer's H with it is the slow obvious sum.

#include "rrr_graphslam/core/dense_factor.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "marginalization_test_graphs.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/marginalization.h"
#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {
namespace {

using test_graphs::expectInvalidArgumentMentioning;
using test_graphs::optimizedThinLoop;
using test_graphs::posesOf;
using test_graphs::randomChainWithLoops;
using test_graphs::run;

double maxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

// The graph without `removed` and the constraints touching them, with `factors` added.
PoseGraph reducedGraph(const PoseGraph& graph, const std::vector<NodeId>& removed,
                       const std::vector<DenseFactor>& factors) {
  auto isRemoved = [&](NodeId id) {
    return std::find(removed.begin(), removed.end(), id) != removed.end();
  };
  PoseGraph out;
  for (NodeId id : graph.nodeIds()) {
    if (!isRemoved(id)) out.addNode(id, graph.pose(id));
  }
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const PoseGraph::Edge& e = graph.edge(k);
    if (isRemoved(e.from) || isRemoved(e.to)) continue;
    out.addEdge(e.from, e.to, graph.measurement(k), graph.information(k), e.kind);
  }
  for (const DenseFactor& f : graph.denseFactors()) out.addDenseFactor(f);
  for (const DenseFactor& f : factors) out.addDenseFactor(f);
  return out;
}

// The factors' quadratic model over the marginal's blanket at its linearization point.
QuadraticModel modelOf(const std::vector<DenseFactor>& factors, const Marginal& marginal) {
  return linearizeConstraints({}, factors, marginal.blanket, marginal.linearization_point);
}

TEST(DenseFactor, GivesTheMarginalBackAtItsLinearizationPoint) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    const int n = std::uniform_int_distribution<int>(20, 60)(rng);
    const int count = std::uniform_int_distribution<int>(3, 12)(rng);
    const int first = std::uniform_int_distribution<int>(1, n - count - 1)(rng);
    const PoseGraph graph = randomChainWithLoops(n, seed, n / 4);  // away from its minimum
    const Marginal marginal = marginalizeNodes(graph, run(first, count));
    const std::vector<DenseFactor> factors = denseFactors(marginal);
    ASSERT_FALSE(factors.empty()) << seed;
    for (const DenseFactor& f : factors) {
      EXPECT_EQ(denseFactorProblem(f), "") << seed;
      EXPECT_EQ(f.information, Eigen::MatrixXd(f.information.transpose())) << "exactly symmetric";
    }
    const QuadraticModel model = modelOf(factors, marginal);
    EXPECT_LT(maxAbs(model.information - marginal.information), 1e-9 * maxAbs(marginal.information))
        << seed;
    EXPECT_LT((model.gradient - marginal.gradient).cwiseAbs().maxCoeff(),
              1e-9 * marginal.gradient.cwiseAbs().maxCoeff())
        << seed;
    EXPECT_NEAR(model.chi2_at_linearization, marginal.chi2_at_linearization,
                1e-9 * marginal.chi2_at_linearization)
        << seed;
    EXPECT_GT(marginal.gradient.norm(), 0.0) << "the linear term is exercised";
  }
}

TEST(DenseFactor, IsInvariantToARigidMotionOfTheGraph) {
  const PoseGraph graph = randomChainWithLoops(30, 3, 8);
  const Marginal marginal = marginalizeNodes(graph, run(10, 6));
  const std::vector<DenseFactor> factors = denseFactors(marginal);
  ASSERT_EQ(factors.size(), 1u);
  const DenseFactor& f = factors.front();
  std::vector<Pose2> at;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (NodeId id : f.nodes) {
    const Pose2 p = graph.pose(id);
    at.push_back(Pose2(p.x() + noise(rng), p.y() + noise(rng), normalizeAngle(p.z() + noise(rng))));
  }
  const double chi2 = denseFactorChi2(f, at);
  for (const Pose2& motion : {Pose2(100.0, -40.0, 3.0), Pose2(-5.0, 2.0, -2.5)}) {
    std::vector<Pose2> moved;
    for (const Pose2& p : at) moved.push_back(compose(motion, p));
    EXPECT_NEAR(denseFactorChi2(f, moved), chi2, 1e-9 * chi2);
  }
  // The linear model is not: its additive perturbation sees the motion.
  std::vector<Pose2> moved_blanket;
  for (const Pose2& p : marginal.linearization_point) {
    moved_blanket.push_back(compose(Pose2(0.0, 0.0, 1.0), p));
  }
  EXPECT_GT(marginalChi2(marginal, moved_blanket), 10.0 * marginal.chi2_at_linearization);
  std::vector<Pose2> moved_factor;
  for (NodeId id : f.nodes) moved_factor.push_back(compose(Pose2(0.0, 0.0, 1.0), graph.pose(id)));
  EXPECT_NEAR(denseFactorChi2(f, moved_factor), marginal.chi2_at_linearization,
              1e-9 * marginal.chi2_at_linearization);
}

// At the full graph's minimum, the graph that keeps the dense factor in place of the removed
// nodes has its minimum there too, with the same chi2; from elsewhere it converges back to it.
TEST(DenseFactor, TheReducedGraphKeepsTheFullGraphsMinimum) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const PoseGraph full = optimizedThinLoop(seed);
    Optimizer full_optimizer = makeOptimizer(full);
    const double full_chi2 = full_optimizer.chi2();
    const std::vector<NodeId> removed = run(10, 10);
    const Marginal marginal = marginalizeNodes(full, removed);
    ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{9, 20, 23, 26, 29})) << seed;
    const PoseGraph reduced = reducedGraph(full, removed, denseFactors(marginal));
    ASSERT_EQ(reduced.denseFactors().size(), 1u);
    ASSERT_EQ(reduced.connectedComponents().size(), 1u);

    Optimizer optimizer = makeOptimizer(reduced);
    EXPECT_NEAR(optimizer.chi2(), full_chi2, 1e-6 * full_chi2) << seed;
    const OptimizationResult at_minimum = optimizer.optimize();
    EXPECT_TRUE(at_minimum.converged()) << seed;
    double moved = 0.0;
    const std::vector<NodeId> ids = reduced.nodeIds();
    for (std::size_t k = 0; k < ids.size(); ++k) {
      moved = std::max(moved, (optimizer.poses()[k] - reduced.pose(ids[k])).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(moved, 1e-6) << seed;
    EXPECT_NEAR(at_minimum.final_chi2, full_chi2, 1e-6 * full_chi2) << seed;

    // From poses 5 cm / 0.02 rad off, it goes back to the same poses (to a tight tolerance: the
    // default stops within ~1e-4 m).
    optimizer.params().relative_tolerance = 1e-12;
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<Pose2> start = optimizer.poses();
    for (std::size_t k = 1; k < start.size(); ++k) {
      start[k] += Pose2(0.05 * noise(rng), 0.05 * noise(rng), 0.02 * noise(rng));
    }
    const OptimizationResult from_elsewhere = optimizer.optimize(startFrom(start));
    EXPECT_TRUE(from_elsewhere.converged()) << seed;
    double error = 0.0;
    for (std::size_t k = 0; k < ids.size(); ++k) {
      error = std::max(error, (optimizer.poses()[k] - reduced.pose(ids[k])).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(error, 1e-6) << seed;
  }
}

// The Schur complement in two steps through the dense factor equals the one-step one.
TEST(DenseFactor, MarginalizingThroughItEqualsMarginalizingAtOnce) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const PoseGraph graph = randomChainWithLoops(40, seed, 10);
    const std::vector<NodeId> first = run(8, 6), second = run(14, 5);
    std::vector<NodeId> both = first;
    both.insert(both.end(), second.begin(), second.end());
    const Marginal at_once = marginalizeNodes(graph, both);
    const PoseGraph reduced =
        reducedGraph(graph, first, denseFactors(marginalizeNodes(graph, first)));
    const Marginal sparse = marginalizeNodes(reduced, second);
    ASSERT_EQ(sparse.blanket, at_once.blanket) << seed;
    EXPECT_FALSE(sparse.removed_factors.empty()) << seed;
    // The sparse path against the dense one, with the factor among the removed terms.
    std::map<NodeId, Pose2> poses = posesOf(reduced);
    const Marginal dense =
        marginalizeNodesDense(constraintsOf(reduced), reduced.denseFactors(), poses, second);
    EXPECT_EQ(sparse.removed_factors, dense.removed_factors) << seed;
    for (const Marginal* m : {&sparse, &dense}) {
      EXPECT_LT(maxAbs(m->information - at_once.information), 1e-8 * maxAbs(at_once.information))
          << seed;
      EXPECT_LT((m->gradient - at_once.gradient).cwiseAbs().maxCoeff(),
                1e-8 * at_once.gradient.cwiseAbs().maxCoeff())
          << seed;
      EXPECT_NEAR(m->chi2_at_linearization, at_once.chi2_at_linearization,
                  1e-8 * at_once.chi2_at_linearization)
          << seed;
    }
  }
}

// The optimizer's H and chi2 with dense factors, against the slow obvious sum.
TEST(DenseFactor, OptimizerInformationAndChi2MatchTheObviousSum) {
  const PoseGraph graph = randomChainWithLoops(30, 7, 8);
  const std::vector<NodeId> removed = run(5, 4);
  const PoseGraph reduced =
      reducedGraph(graph, removed, denseFactors(marginalizeNodes(graph, removed)));
  const Optimizer optimizer = makeOptimizer(reduced);
  const std::vector<NodeId> ids = reduced.nodeIds();
  std::vector<Pose2> poses;
  for (NodeId id : ids) poses.push_back(reduced.pose(id));
  const QuadraticModel obvious =
      linearizeConstraints(constraintsOf(reduced), reduced.denseFactors(), ids, poses);
  const Eigen::MatrixXd H = Eigen::MatrixXd(optimizer.informationMatrix());
  EXPECT_LT(maxAbs(H - obvious.information), 1e-9 * maxAbs(obvious.information));
  EXPECT_NEAR(optimizer.chi2(), obvious.chi2_at_linearization,
              1e-9 * obvious.chi2_at_linearization);
  EXPECT_NEAR(optimizer.weightedChi2(), optimizer.chi2(), 1e-12 * optimizer.chi2());
}

// Numerical Jacobian of the residual, through the factor's chi2: the Gauss-Newton gradient of a
// factor is half the chi2's gradient.
TEST(DenseFactor, GradientMatchesNumericalDifferentiation) {
  const PoseGraph graph = randomChainWithLoops(25, 11, 6);
  const std::vector<DenseFactor> factors = denseFactors(marginalizeNodes(graph, run(6, 5)));
  ASSERT_EQ(factors.size(), 1u);
  const DenseFactor& f = factors.front();
  std::vector<Pose2> at;
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (NodeId id : f.nodes)
    at.push_back(graph.pose(id) + Pose2(noise(rng), noise(rng), noise(rng)));
  const DenseFactorLinearization lin = linearize(f, at);
  EXPECT_NEAR(lin.chi2, denseFactorChi2(f, at), 1e-12 * lin.chi2);
  const double h = 1e-6;
  for (std::size_t i = 0; i < at.size(); ++i) {
    for (int q = 0; q < 3; ++q) {
      std::vector<Pose2> plus = at, minus = at;
      plus[i][q] += h;
      minus[i][q] -= h;
      const double numeric = (denseFactorChi2(f, plus) - denseFactorChi2(f, minus)) / (4.0 * h);
      EXPECT_NEAR(lin.gradient(static_cast<Eigen::Index>(3 * i + q)), numeric,
                  1e-5 * (1.0 + std::abs(numeric)))
          << "node " << i << " axis " << q;
    }
  }
}

// LAGO takes a dense factor's residual blocks as relative poses: a part of a chain held to the
// rest by the factor alone, moved 5 m and 1 rad away, comes back near its minimum.
TEST(DenseFactor, LagoFollowsItAcrossAGap) {
  PoseGraph chain = randomChainWithLoops(30, 9, 0, 0.0);  // noise-free: its minimum is its poses
  const std::vector<NodeId> removed = run(10, 5);
  const PoseGraph reduced =
      reducedGraph(chain, removed, denseFactors(marginalizeNodes(chain, removed)));
  ASSERT_EQ(reduced.connectedComponents().size(), 1u);
  Optimizer optimizer = makeOptimizer(reduced);
  const std::vector<Pose2> minimum = optimizer.poses();
  std::vector<Pose2> moved = minimum;
  const std::vector<NodeId> ids = reduced.nodeIds();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] >= 15) moved[k] = compose(Pose2(5.0, -3.0, 1.0), minimum[k]);
  }
  optimizer.setPoses(moved);
  EXPECT_GT(optimizer.chi2(), 100.0) << "the factor sees the gap";
  const std::vector<Pose2> start = lagoInitialization(optimizer);
  double error = 0.0;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    error = std::max(error, (start[k].head<2>() - minimum[k].head<2>()).norm());
  }
  EXPECT_LT(error, 0.01);
}

TEST(DenseFactor, OnePerPieceOfTheBlanket) {
  // Removing 10..14 and 30..33 at once: two pieces, two factors, their offsets summing to the
  // marginal's chi2 minus what the factors can move away.
  const PoseGraph graph = randomChainWithLoops(45, 5, 0);
  std::vector<NodeId> removed = run(10, 5);
  const std::vector<NodeId> more = run(30, 4);
  removed.insert(removed.end(), more.begin(), more.end());
  const Marginal marginal = marginalizeNodes(graph, removed);
  ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{9, 15, 29, 34}));
  const std::vector<DenseFactor> factors = denseFactors(marginal);
  ASSERT_EQ(factors.size(), 2u);
  EXPECT_EQ(factors[0].nodes, (std::vector<mrpt::graphs::TNodeID>{9, 15}));
  EXPECT_EQ(factors[1].nodes, (std::vector<mrpt::graphs::TNodeID>{29, 34}));
  EXPECT_GE(factors[0].chi2_offset, 0.0);
  EXPECT_EQ(factors[1].chi2_offset, 0.0);
  const QuadraticModel model = modelOf(factors, marginal);
  EXPECT_NEAR(model.chi2_at_linearization, marginal.chi2_at_linearization,
              1e-9 * marginal.chi2_at_linearization);
}

TEST(DenseFactor, BadFactorsAreRefusedWithTheReason) {
  const PoseGraph graph = randomChainWithLoops(20, 1, 4);
  const DenseFactor good = denseFactors(marginalizeNodes(graph, run(5, 3))).front();
  EXPECT_EQ(denseFactorProblem(good), "");
  DenseFactor one = good;
  one.nodes.resize(1);
  EXPECT_NE(denseFactorProblem(one).find("at least two"), std::string::npos);
  DenseFactor twice = good;
  twice.nodes[1] = twice.nodes[0];
  EXPECT_NE(denseFactorProblem(twice).find("listed twice"), std::string::npos);
  DenseFactor sizes = good;
  sizes.mean.resize(2);
  EXPECT_NE(denseFactorProblem(sizes).find("sizes do not match"), std::string::npos);
  DenseFactor nan = good;
  nan.information(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(denseFactorProblem(nan).find("not finite"), std::string::npos);
  DenseFactor indefinite = good;
  indefinite.information(1, 1) = -1.0;
  EXPECT_NE(denseFactorProblem(indefinite).find("not positive definite"), std::string::npos);
  DenseFactor negative = good;
  negative.chi2_offset = -1.0;
  EXPECT_NE(denseFactorProblem(negative).find("offset"), std::string::npos);

  PoseGraph copy = graph;
  DenseFactor unknown = good;
  unknown.nodes[0] = 999;
  expectInvalidArgumentMentioning([&] { copy.addDenseFactor(unknown); }, "unknown node 999");
  expectInvalidArgumentMentioning([&] { copy.addDenseFactor(indefinite); }, "positive definite");
  Optimizer optimizer = makeOptimizer(graph);
  expectInvalidArgumentMentioning([&] { optimizer.addDenseFactor({0}, good); },
                                  "nodes for a factor");
  EXPECT_EQ(copy.denseFactors().size(), 0u) << "nothing half-added";
}

TEST(DenseFactor, ThePoseGraphKeepsItThroughACopyAndJoinsComponents) {
  PoseGraph graph;
  for (NodeId id = 0; id < 4; ++id) graph.addNode(id, Pose2(static_cast<double>(id), 0.0, 0.0));
  graph.addEdge(0, 1, Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity(), EdgeKind::kOdometry);
  graph.addEdge(2, 3, Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity(), EdgeKind::kOdometry);
  EXPECT_EQ(graph.connectedComponents().size(), 2u);
  DenseFactor f;
  f.nodes = {1, 2};
  f.measurements = {Pose2(1.0, 0.0, 0.0)};
  f.mean = Eigen::Vector3d::Zero();
  f.information = Eigen::Matrix3d::Identity();
  graph.addDenseFactor(f);
  EXPECT_EQ(graph.connectedComponents().size(), 1u);
  const PoseGraph copy = graph;
  ASSERT_EQ(copy.denseFactors().size(), 1u);
  EXPECT_EQ(copy.denseFactors()[0].nodes, f.nodes);
  // A two-node dense factor with zero mean and offset is the relative-pose edge it measures.
  PoseGraph plain;
  for (NodeId id = 0; id < 4; ++id) plain.addNode(id, Pose2(0.3 * id, 0.1 * id, 0.05 * id));
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    plain.addEdge(graph.edge(k).from, graph.edge(k).to, graph.measurement(k), graph.information(k),
                  EdgeKind::kOdometry);
  }
  PoseGraph as_factor = plain;
  as_factor.addDenseFactor(f);
  plain.addEdge(1, 2, f.measurements[0], f.information, EdgeKind::kMarginal);
  Optimizer a = makeOptimizer(plain), b = makeOptimizer(as_factor);
  EXPECT_NEAR(a.chi2(), b.chi2(), 1e-12 * a.chi2());
  a.optimize();
  b.optimize();
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_LT((a.poses()[k] - b.poses()[k]).cwiseAbs().maxCoeff(), 1e-9);
  }
}

}  // namespace
}  // namespace rrr_graphslam::core
