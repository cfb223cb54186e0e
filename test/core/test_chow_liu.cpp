// Chow-Liu sparsification: a tree-shaped marginal comes back exactly, the tree is the best of
// all spanning trees on small blankets (exhaustive search), the matched gradient is the
// marginal's, pieces give a forest, bad marginals throw, and on an optimized loop the tree loses
// less than a tenth of what deleting the constraints loses.

#include "rrr_graphslam/core/chow_liu.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <random>
#include <set>
#include <utility>

#include "marginalization_test_graphs.h"
#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/core/gaussian_kl.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::core {
namespace {

using test_graphs::expectInvalidArgumentMentioning;
using test_graphs::optimizedThinLoop;
using test_graphs::randomChainWithLoops;
using test_graphs::randomInformation;
using test_graphs::run;

// A hand-made marginal: the quadratic model of `constraints` over `blanket` at `poses`.
Marginal handMade(const std::vector<NodeId>& blanket, const std::vector<Pose2>& poses,
                  const std::vector<PoseConstraint>& constraints) {
  const QuadraticModel model = linearizeConstraints(constraints, blanket, poses);
  Marginal marginal;
  marginal.blanket = blanket;
  marginal.linearization_point = poses;
  marginal.information = model.information;
  marginal.gradient = model.gradient;
  marginal.chi2_at_linearization = model.chi2_at_linearization;
  return marginal;
}

std::set<std::pair<NodeId, NodeId>> edgeSet(const std::vector<ChowLiuEdge>& tree) {
  std::set<std::pair<NodeId, NodeId>> pairs;
  for (const ChowLiuEdge& e : tree) pairs.emplace(e.constraint.from, e.constraint.to);
  return pairs;
}

// A marginal that is itself a tree of relative-pose constraints (a chain, a star) is its own
// Chow-Liu tree: the same edges with the same information.
TEST(ChowLiu, TreeShapedMarginalComesBackExactly) {
  const std::vector<NodeId> blanket{3, 7, 8, 12, 20};
  const std::vector<Pose2> poses{Pose2(0.0, 0.0, 0.1), Pose2(2.0, 0.5, 1.2),
                                 Pose2(1.0, 3.0, M_PI - 0.05), Pose2(-2.0, 1.0, -M_PI + 0.1),
                                 Pose2(-1.0, -2.0, -1.0)};
  std::mt19937 rng(1);
  auto constraint = [&](std::size_t a, std::size_t b) {
    return PoseConstraint{blanket[a], blanket[b], between(poses[a], poses[b]),
                          randomInformation(rng)};
  };
  const std::vector<std::vector<PoseConstraint>> shapes{
      {constraint(0, 1), constraint(1, 2), constraint(2, 3), constraint(3, 4)},   // chain
      {constraint(0, 2), constraint(1, 2), constraint(2, 3), constraint(2, 4)}};  // star
  for (const auto& shape : shapes) {
    const Marginal marginal = handMade(blanket, poses, shape);
    for (bool match_gradient : {true, false}) {
      ChowLiuParams params;
      params.match_gradient = match_gradient;
      const std::vector<ChowLiuEdge> tree = chowLiuTree(marginal, params);
      ASSERT_EQ(tree.size(), shape.size());
      for (const PoseConstraint& c : shape) {
        const auto it = std::find_if(tree.begin(), tree.end(), [&](const ChowLiuEdge& e) {
          return e.constraint.from == c.from && e.constraint.to == c.to;
        });
        ASSERT_NE(it, tree.end()) << c.from << " - " << c.to;
        EXPECT_LT((it->constraint.information - c.information).norm(), 1e-9 * c.information.norm());
        EXPECT_LT((it->constraint.measurement - c.measurement).norm(), 1e-12);
      }
      for (std::size_t k = 1; k < tree.size(); ++k) {
        EXPECT_GE(tree[k - 1].mutual_information_nats, tree[k].mutual_information_nats);
      }
    }
  }
}

// Small blankets (5 nodes, all 125 spanning trees): the Chow-Liu tree has the smallest
// KL(marginal || tree) of all, each tree's edges carrying their relative pose's exact marginal,
// computed here from the Moore-Penrose pseudo-inverse instead of an anchored inverse.
TEST(ChowLiu, IsTheBestOfAllSpanningTreesOnSmallBlankets) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-5.0, 5.0);
    std::uniform_int_distribution<int> hub(0, 2);
    // Removed nodes 100-102 in a chain; each blanket node 0-4 hangs from one or two of them.
    std::map<NodeId, Pose2> poses;
    for (NodeId id : {0, 1, 2, 3, 4, 100, 101, 102}) {
      poses[id] = Pose2(u(rng), u(rng), normalizeAngle(u(rng)));
    }
    std::vector<PoseConstraint> constraints;
    auto link = [&](NodeId a, NodeId b) {
      constraints.push_back({a, b, between(poses[a], poses[b]), randomInformation(rng)});
    };
    link(100, 101);
    link(101, 102);
    for (NodeId b = 0; b < 5; ++b) link(static_cast<NodeId>(100 + hub(rng)), b);
    link(static_cast<NodeId>(100 + hub(rng)), 1);
    link(3, static_cast<NodeId>(100 + hub(rng)));
    const Marginal marginal = marginalizeNodes(constraints, poses, {100, 101, 102});
    ASSERT_EQ(marginal.blanket.size(), 5u);

    const Eigen::MatrixXd pseudo_inverse =
        marginal.information.completeOrthogonalDecomposition().pseudoInverse();
    std::vector<PoseConstraint> pairs;
    for (std::size_t i = 0; i < 5; ++i) {
      for (std::size_t j = i + 1; j < 5; ++j) {
        const Pose2 &x_i = marginal.linearization_point[i], &x_j = marginal.linearization_point[j];
        const EdgeLinearization lin = linearizeEdge(x_i, x_j, between(x_i, x_j));
        Eigen::Matrix<double, 3, 15> A = Eigen::Matrix<double, 3, 15>::Zero();
        A.middleCols<3>(3 * static_cast<Eigen::Index>(i)) = lin.J_from;
        A.middleCols<3>(3 * static_cast<Eigen::Index>(j)) = lin.J_to;
        const Eigen::Matrix3d sigma = A * pseudo_inverse * A.transpose();
        pairs.push_back(
            {marginal.blanket[i], marginal.blanket[j], between(x_i, x_j), sigma.inverse()});
      }
    }
    // KL(marginal || tree) on the gauge-free distribution: node 0 anchored.
    const Eigen::MatrixXd anchored = marginal.information.bottomRightCorner(12, 12);
    auto klOfTree = [&](const std::vector<PoseConstraint>& tree) {
      const QuadraticModel model =
          linearizeConstraints(tree, marginal.blanket, marginal.linearization_point);
      return gaussianKl(Eigen::VectorXd::Zero(12), anchored, Eigen::VectorXd::Zero(12),
                        model.information.bottomRightCorner(12, 12));
    };
    double best = std::numeric_limits<double>::infinity();
    std::set<std::pair<NodeId, NodeId>> best_edges;
    int trees = 0;
    for (int mask = 0; mask < (1 << 10); ++mask) {
      if (__builtin_popcount(static_cast<unsigned>(mask)) != 4) continue;
      std::vector<PoseConstraint> tree;
      UnionFind spanned(5);
      bool acyclic = true;
      for (std::size_t p = 0; p < pairs.size(); ++p) {
        if (!(mask & (1 << p))) continue;
        tree.push_back(pairs[p]);
        acyclic = acyclic && spanned.unite(pairs[p].from, pairs[p].to);
      }
      if (!acyclic) continue;
      ++trees;
      const double kl = klOfTree(tree);
      if (kl < best) {
        best = kl;
        best_edges.clear();
        for (const PoseConstraint& c : tree) best_edges.emplace(c.from, c.to);
      }
    }
    ASSERT_EQ(trees, 125);  // Cayley: 5^3

    ChowLiuParams params;
    params.match_gradient = false;  // measurements at the linearization point, as above
    params.conservative = false;    // the Chow-Liu tree itself: each edge its exact marginal
    const std::vector<ChowLiuEdge> chow_liu = chowLiuTree(marginal, params);
    std::vector<PoseConstraint> constraints_of_tree;
    for (const ChowLiuEdge& e : chow_liu) constraints_of_tree.push_back(e.constraint);
    EXPECT_NEAR(klOfTree(constraints_of_tree), best, 1e-9 * best) << seed;
    EXPECT_EQ(edgeSet(chow_liu), best_edges) << seed;
    EXPECT_GT(best, 0.1) << "a dense marginal: no tree holds it all";
  }
}

// The tree's constraints, linearized by the optimizer's own functions at the linearization
// point, have the marginal's gradient (match_gradient) or none (measurements between(x_i, x_j)),
// and the same information either way. Each is a valid optimizer constraint.
TEST(ChowLiu, MatchedGradientIsTheMarginals) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const PoseGraph graph = randomChainWithLoops(40, seed, 10);
    const Marginal marginal = marginalizeNodes(graph, run(15, 10));
    ASSERT_GE(marginal.blanket.size(), 3u);
    ChowLiuParams at_linearization;
    at_linearization.match_gradient = false;
    const QuadraticModel matched = replacementModel(marginal, MarginalReplacement::kChowLiuTree);
    const QuadraticModel plain =
        replacementModel(marginal, MarginalReplacement::kChowLiuTree, at_linearization);
    EXPECT_LT((matched.gradient - marginal.gradient).norm(), 1e-9 * marginal.gradient.norm());
    EXPECT_GT(marginal.gradient.norm(), 1.0);
    EXPECT_LT(plain.gradient.norm(), 1e-9 * marginal.gradient.norm());
    EXPECT_LT((matched.information - plain.information).norm(), 1e-9 * plain.information.norm());
    for (const ChowLiuEdge& e : chowLiuTree(marginal)) {
      EXPECT_LT(e.constraint.from, e.constraint.to);
      EXPECT_EQ(informationProblem(e.constraint.information), "");
      EXPECT_EQ(poseProblem(e.constraint.measurement), "");
    }
  }
}

TEST(ChowLiu, BlanketInPiecesGivesAForest) {
  const PoseGraph chain = randomChainWithLoops(30, 12, 0);
  std::vector<NodeId> removed = run(5, 4);
  for (NodeId id : run(20, 4)) removed.push_back(id);
  const Marginal marginal = marginalizeNodes(chain, removed);
  ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{4, 9, 19, 24}));
  const std::vector<ChowLiuEdge> forest = chowLiuTree(marginal);
  EXPECT_EQ(edgeSet(forest), (std::set<std::pair<NodeId, NodeId>>{{4, 9}, {19, 24}}));
  // A single blanket node (a dead end removed) leaves nothing to keep.
  const Marginal end = marginalizeNodes(chain, run(25, 5));
  EXPECT_EQ(end.blanket, (std::vector<NodeId>{24}));
  EXPECT_TRUE(chowLiuTree(end).empty());
}

// Two pieces of several nodes each (two removed runs, each with loops to its own side of the
// chain): a tree per piece, and the matched gradient (solved along each tree from its leaves)
// is the marginal's in both pieces, with one scale per piece or per edge.
TEST(ChowLiu, ForestOfLargePiecesKeepsTheGradientOfEach) {
  PoseGraph chain = randomChainWithLoops(40, 5, 0);
  std::mt19937 rng(8);
  const auto noisy = [&](NodeId a, NodeId b) {
    Pose2 d = between(chain.pose(a), chain.pose(b));
    d.x() += 0.05;
    d.z() = normalizeAngle(d.z() - 0.02);
    return d;
  };
  for (const auto& [a, b] : std::vector<std::pair<NodeId, NodeId>>{
           {6, 12}, {8, 15}, {9, 17}, {26, 20}, {27, 33}, {29, 36}}) {
    chain.addEdge(a, b, noisy(a, b), randomInformation(rng), EdgeKind::kLoopCandidate);
  }
  std::vector<NodeId> removed = run(5, 5);
  for (NodeId id : run(25, 5)) removed.push_back(id);
  const Marginal marginal = marginalizeNodes(chain, removed);
  ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{4, 10, 12, 15, 17, 20, 24, 30, 33, 36}));
  for (bool per_edge : {true, false}) {
    ChowLiuParams params;
    params.per_edge_scaling = per_edge;
    const std::vector<ChowLiuEdge> forest = chowLiuTree(marginal, params);
    ASSERT_EQ(forest.size(), 8u) << "two trees of 5 nodes";
    for (const ChowLiuEdge& e : forest) {
      EXPECT_EQ(e.constraint.from < 20, e.constraint.to < 20) << "an edge between the pieces";
    }
    const QuadraticModel tree =
        replacementModel(marginal, MarginalReplacement::kChowLiuTree, params);
    EXPECT_GT(marginal.gradient.norm(), 1e-3);
    EXPECT_LT((tree.gradient - marginal.gradient).norm(), 1e-9 * marginal.gradient.norm())
        << per_edge;
  }
}

TEST(ChowLiu, BadMarginalThrowsNamingTheProblem) {
  const std::vector<NodeId> blanket{1, 2, 5};
  const std::vector<Pose2> poses{Pose2(0.0, 0.0, 0.0), Pose2(1.0, 0.0, 0.5), Pose2(1.0, 1.0, 1.0)};
  // 1 - 2 carries no information on the heading: rank 5 with node 1 anchored, not 6.
  const Eigen::Matrix3d no_heading = Eigen::Vector3d(100.0, 100.0, 0.0).asDiagonal();
  const Marginal singular =
      handMade(blanket, poses,
               {{1, 2, between(poses[0], poses[1]), no_heading},
                {2, 5, between(poses[1], poses[2]), Eigen::Matrix3d::Identity()}});
  expectInvalidArgumentMentioning([&] { chowLiuTree(singular); },
                                  "blanket nodes {1, 2, 5} is singular beyond its gauge");

  Marginal good = handMade(blanket, poses,
                           {{1, 2, between(poses[0], poses[1]), Eigen::Matrix3d::Identity()},
                            {2, 5, between(poses[1], poses[2]), Eigen::Matrix3d::Identity()}});
  EXPECT_EQ(chowLiuTree(good).size(), 2u);
  Marginal bad = good;
  bad.linearization_point.pop_back();
  expectInvalidArgumentMentioning([&] { chowLiuTree(bad); }, "sizes disagree");
  bad = good;
  bad.information(0, 4) = std::numeric_limits<double>::quiet_NaN();
  expectInvalidArgumentMentioning([&] { chowLiuTree(bad); }, "not finite");
  bad = good;
  bad.information(0, 4) += 1.0;
  expectInvalidArgumentMentioning([&] { chowLiuTree(bad); }, "not symmetric");
}

// The target on a realistic case: an optimized 40-node loop with closures across it,
// nodes 10-19 marginalized (blanket {9, 20, 23, 26, 29}). The graph's covariance over the
// blanket comes from the optimizer, as the integration will take it.
TEST(ChowLiu, TreeLosesUnderATenthOfWhatDeletingLosesOnALoop) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const PoseGraph graph = optimizedThinLoop(seed);
    const Marginal marginal = marginalizeNodes(graph, run(10, 10));
    ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{9, 20, 23, 26, 29}));
    Optimizer optimizer = makeOptimizer(graph);
    ASSERT_TRUE(optimizer.optimize().converged());
    ASSERT_TRUE(optimizer.covarianceAvailable());
    const Eigen::MatrixXd covariance =
        optimizer.covariance(std::vector<int>(marginal.blanket.begin(), marginal.blanket.end()));

    auto kl = [&](MarginalReplacement replacement, const ChowLiuParams& params) {
      return replacementKl(covariance, marginal, replacementModel(marginal, replacement, params));
    };
    ChowLiuParams at_linearization;
    at_linearization.match_gradient = false;
    ChowLiuParams plain;
    plain.conservative = false;
    at_linearization.conservative = false;
    const double tree = kl(MarginalReplacement::kChowLiuTree, plain);
    const double tree_without_gradient = kl(MarginalReplacement::kChowLiuTree, at_linearization);
    const double conservative = kl(MarginalReplacement::kChowLiuTree, {});
    const double deleted = kl(MarginalReplacement::kDelete, {});
    EXPECT_LT(tree, 0.1 * deleted) << seed;
    EXPECT_GT(tree, 0.0);
    // Dropping the marginal's gradient loses several times more.
    EXPECT_GT(tree_without_gradient, 3.0 * tree) << seed;
    // The conservative tree pays for its guarantee here (about 0.05 -> 0.10 of deletion's loss):
    // nothing in this single loop holds the blanket tightly enough for the plain tree's
    // overstatement to cost much (doc/lifelong.md: on maps of several sessions it does).
    EXPECT_GT(conservative, tree) << seed;
    EXPECT_LT(conservative, 0.15 * deleted) << seed;
    EXPECT_NEAR(kl(MarginalReplacement::kDense, {}), 0.0, 1e-12);
  }
}

// The largest generalized eigenvalue of `information` against `marginal`'s, with each piece's
// first node anchored (the blanket here is one piece): how much more the replacement claims
// than the marginal in its most overstated direction.
double largestOverstatement(const Marginal& marginal, const Eigen::MatrixXd& information) {
  const Eigen::Index k = marginal.information.rows() - 3;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eigen(
      information.bottomRightCorner(k, k), marginal.information.bottomRightCorner(k, k),
      Eigen::EigenvaluesOnly);
  return eigen.eigenvalues().maxCoeff();
}

// KL(marginal || replacement) over the anchored blanket from their information alone (no mean
// shift): in the tree's coordinates 3/2 sum_e (s_e - ln s_e) + const, what the per-edge scales
// minimize along their segment.
double blanketKl(const Marginal& marginal, const Eigen::MatrixXd& information) {
  const Eigen::Index k = marginal.information.rows() - 3;
  const Eigen::MatrixXd sigma = marginal.information.bottomRightCorner(k, k).inverse();
  const Eigen::MatrixXd product = information.bottomRightCorner(k, k) * sigma;
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(product);
  const double log_det = lu.matrixLU().diagonal().array().abs().log().sum();
  return 0.5 * (product.trace() - log_det - static_cast<double>(k));
}

// The plain Chow-Liu tree overstates the marginal's information in some direction (its edges'
// relative poses are taken as independent); the conservative one never does. With one scale for
// all edges it is tight: in the most overstated direction it states exactly what the marginal
// does. With per-edge scales (the default) it never loses more than that over the blanket, and
// on large blankets less. Its measurements still give the marginal's gradient.
// Blankets of 3-10 nodes and of more than 30 (the largest eigenvalue then comes from Lanczos).
TEST(ChowLiu, ConservativeTreeNeverStatesMoreThanTheMarginal) {
  int shrunk = 0, per_edge_better = 0;
  for (unsigned seed = 1; seed <= 14; ++seed) {
    const bool large = seed > 10;
    const PoseGraph graph =
        large ? randomChainWithLoops(300, seed, 200) : randomChainWithLoops(40, seed, 10);
    const Marginal marginal = marginalizeNodes(graph, large ? run(100, 60) : run(15, 10));
    ASSERT_GE(marginal.blanket.size(), large ? 30u : 3u);
    ChowLiuParams plain;
    plain.conservative = false;
    const QuadraticModel conservative =
        replacementModel(marginal, MarginalReplacement::kChowLiuTree);
    const QuadraticModel overstated =
        replacementModel(marginal, MarginalReplacement::kChowLiuTree, plain);
    ChowLiuParams uniform;
    uniform.per_edge_scaling = false;
    const QuadraticModel one_scale =
        replacementModel(marginal, MarginalReplacement::kChowLiuTree, uniform);
    const double scale = largestOverstatement(marginal, overstated.information);
    EXPECT_GT(scale, 1.01) << seed;
    EXPECT_NEAR(largestOverstatement(marginal, one_scale.information), 1.0, 1e-9) << seed;
    EXPECT_LT((scale * one_scale.information - overstated.information).norm(),
              1e-9 * overstated.information.norm())
        << seed;
    EXPECT_LE(largestOverstatement(marginal, conservative.information), 1.0 + 1e-9) << seed;
    const double kl_per_edge = blanketKl(marginal, conservative.information);
    const double kl_one_scale = blanketKl(marginal, one_scale.information);
    EXPECT_LE(kl_per_edge, kl_one_scale * (1.0 + 1e-9)) << seed;
    if (large) per_edge_better += kl_per_edge < 0.9 * kl_one_scale;
    // The marginal's gradient, or where the offsets that takes would turn the measurements by
    // more than 90 degrees (the large blankets of these unoptimized graphs), a fraction of it.
    const double fraction =
        conservative.gradient.dot(marginal.gradient) / marginal.gradient.squaredNorm();
    EXPECT_GT(fraction, 0.0) << seed;
    EXPECT_LE(fraction, 1.0 + 1e-9) << seed;
    if (!large) {
      EXPECT_NEAR(fraction, 1.0, 1e-9) << seed;
    }
    shrunk += fraction < 0.9;
    for (const ChowLiuEdge& e : chowLiuTree(marginal)) {
      const auto at = [&](NodeId id) {
        return marginal.linearization_point[static_cast<std::size_t>(
            std::find(marginal.blanket.begin(), marginal.blanket.end(), id) -
            marginal.blanket.begin())];
      };
      const Pose2 d = between(at(e.constraint.from), at(e.constraint.to));
      EXPECT_LE(std::abs(normalizeAngle(d.z() - e.constraint.measurement.z())), M_PI / 2 + 1e-9);
    }
    EXPECT_LT((conservative.gradient - fraction * marginal.gradient).norm(),
              1e-9 * marginal.gradient.norm())
        << seed;
  }
  EXPECT_GT(shrunk, 0) << "no blanket whose offsets were shrunk: that path is untested";
  // Measured: 0.76-0.96 of one scale's loss on the 4 large blankets, 0.98-1 on the small ones.
  EXPECT_GE(per_edge_better, 2) << "per-edge scales lost 10% less than one scale on too few";
}

// Because the conservative tree lies between nothing and the marginal (in information) and keeps
// the marginal's gradient, it can never lose more than deleting the removed constraints does,
// whatever the rest of the graph holds (the plain tree can: test_map_trimming's room).
TEST(ChowLiu, ConservativeTreeNeverLosesMoreThanDeleting) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    PoseGraph graph = randomChainWithLoops(40, seed, 20);
    OptimizerParams tight;
    tight.relative_tolerance = 1e-15;
    tight.step_tolerance = 1e-12;
    Optimizer optimizer = makeOptimizer(graph, tight);
    ASSERT_TRUE(optimizer.optimize().converged());
    copyPosesToGraph(optimizer, graph);  // the marginal's linearization point: the minimum
    const Marginal at_minimum = marginalizeNodes(graph, run(15, 10));
    const Eigen::MatrixXd covariance = optimizer.covariance(
        std::vector<int>(at_minimum.blanket.begin(), at_minimum.blanket.end()));
    auto kl = [&](MarginalReplacement replacement, const ChowLiuParams& params) {
      return replacementKl(covariance, at_minimum,
                           replacementModel(at_minimum, replacement, params));
    };
    const double deleted = kl(MarginalReplacement::kDelete, {});
    const double tree = kl(MarginalReplacement::kChowLiuTree, {});
    EXPECT_LE(tree, deleted * (1.0 + 1e-9)) << seed;
    EXPECT_GE(tree, 0.0) << seed;
  }
}

}  // namespace
}  // namespace rrr_graphslam::core
