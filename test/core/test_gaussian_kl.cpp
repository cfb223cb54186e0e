// KL divergences: the closed form against a Monte Carlo estimate, the factor-change form against
// the closed form, and replacementKl (O(blanket)) against the KL of the whole graph's linearized
// distributions built densely, for either gauge fixing of the blanket's covariance.

#include "rrr_graphslam/core/gaussian_kl.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "marginalization_test_graphs.h"
#include "rrr_graphslam/core/chow_liu.h"

namespace rrr_graphslam::core {
namespace {

using test_graphs::optimizedThinLoop;
using test_graphs::randomChainWithLoops;

Eigen::MatrixXd randomSpd(int k, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd A(k, k);
  for (int r = 0; r < k; ++r) {
    for (int c = 0; c < k; ++c) A(r, c) = n(rng);
  }
  return A * A.transpose() + 0.5 * Eigen::MatrixXd::Identity(k, k);
}

Eigen::VectorXd randomVector(int k, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd v(k);
  for (int r = 0; r < k; ++r) v(r) = n(rng);
  return v;
}

// E_p0[ln p0 - ln p1] by sampling p0 (fixed seed); the tolerance is 4 standard errors of the
// estimate, which is itself checked to be small.
TEST(GaussianKl, ClosedFormMatchesMonteCarlo) {
  std::mt19937 rng(42);
  const int k = 4;
  const Eigen::MatrixXd information0 = randomSpd(k, rng), information1 = randomSpd(k, rng);
  const Eigen::VectorXd mean0 = randomVector(k, rng), mean1 = 0.5 * randomVector(k, rng);
  const double closed_form = gaussianKl(mean0, information0, mean1, information1);

  const Eigen::MatrixXd L0 = information0.inverse().llt().matrixL();
  const double log_det0 = std::log(information0.determinant());
  const double log_det1 = std::log(information1.determinant());
  const int samples = 200000;
  double sum = 0.0, sum_squares = 0.0;
  for (int s = 0; s < samples; ++s) {
    const Eigen::VectorXd x = mean0 + L0 * randomVector(k, rng);
    const Eigen::VectorXd d0 = x - mean0, d1 = x - mean1;
    const double log_ratio =
        0.5 * (log_det0 - d0.dot(information0 * d0) - log_det1 + d1.dot(information1 * d1));
    sum += log_ratio;
    sum_squares += log_ratio * log_ratio;
  }
  const double estimate = sum / samples;
  const double standard_error = std::sqrt((sum_squares / samples - estimate * estimate) / samples);
  EXPECT_GT(closed_form, 1.0);
  EXPECT_LT(standard_error, 0.02 * closed_form);
  EXPECT_NEAR(estimate, closed_form, 4.0 * standard_error);
  EXPECT_NEAR(gaussianKl(mean0, information0, mean0, information0), 0.0, 1e-12);
}

// p1 = p0 exp(-1/2 x^T D x - d^T x) with p0 = N(0, Sigma0): Lambda1 = Lambda0 + D and
// mean1 = -Lambda1^-1 d.
TEST(GaussianKl, FactorChangeMatchesTheClosedForm) {
  std::mt19937 rng(7);
  const int k = 6;
  const Eigen::MatrixXd information0 = randomSpd(k, rng);
  const Eigen::MatrixXd change = 0.5 * randomSpd(k, rng) - 0.3 * Eigen::MatrixXd::Identity(k, k);
  const Eigen::VectorXd gradient_change = randomVector(k, rng);
  const Eigen::MatrixXd information1 = information0 + change;
  ASSERT_EQ(information1.llt().info(), Eigen::Success);
  const double expected = gaussianKl(Eigen::VectorXd::Zero(k), information0,
                                     -information1.llt().solve(gradient_change), information1);
  EXPECT_NEAR(klOfFactorChange(information0.inverse(), change, gradient_change), expected,
              1e-9 * expected);
  EXPECT_NEAR(klOfFactorChange(information0.inverse(), Eigen::MatrixXd::Zero(k, k),
                               Eigen::VectorXd::Zero(k)),
              0.0, 1e-12);
}

// The linearized distribution of the graph without M, with `blanket_model` added over the
// blanket, with node `anchor` held: information and mean over the other kept nodes.
struct Linearized {
  std::vector<NodeId> nodes;  // kept nodes but the anchor
  Eigen::MatrixXd information;
  Eigen::VectorXd mean;
};

Linearized withReplacement(const PoseGraph& graph, const Marginal& marginal,
                           const QuadraticModel& blanket_model, NodeId anchor) {
  std::vector<NodeId> kept;
  std::vector<Pose2> poses;
  for (NodeId id : graph.nodeIds()) {
    if (std::binary_search(marginal.removed_nodes.begin(), marginal.removed_nodes.end(), id)) {
      continue;
    }
    kept.push_back(id);
    poses.push_back(graph.pose(id));
  }
  std::vector<PoseConstraint> rest;
  const std::vector<PoseConstraint> constraints = constraintsOf(graph);
  for (std::size_t k = 0; k < constraints.size(); ++k) {
    if (!std::binary_search(marginal.removed_constraints.begin(),
                            marginal.removed_constraints.end(), k)) {
      rest.push_back(constraints[k]);
    }
  }
  QuadraticModel model = linearizeConstraints(rest, kept, poses);
  auto at = [&](std::size_t blanket_index) {
    return 3 *
           (std::find(kept.begin(), kept.end(), marginal.blanket[blanket_index]) - kept.begin());
  };
  for (std::size_t i = 0; i < marginal.blanket.size(); ++i) {
    const auto bi = 3 * static_cast<Eigen::Index>(i);
    model.gradient.segment<3>(at(i)) += blanket_model.gradient.segment<3>(bi);
    for (std::size_t j = 0; j < marginal.blanket.size(); ++j) {
      model.information.block<3, 3>(at(i), at(j)) +=
          blanket_model.information.block<3, 3>(bi, 3 * static_cast<Eigen::Index>(j));
    }
  }
  std::vector<Eigen::Index> free;
  Linearized out;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    if (kept[k] == anchor) continue;
    out.nodes.push_back(kept[k]);
    for (int r = 0; r < 3; ++r) free.push_back(3 * static_cast<Eigen::Index>(k) + r);
  }
  out.information = model.information(free, free);
  out.mean = -out.information.llt().solve(model.gradient(free));
  return out;
}

// The blanket's joint covariance (zero rows and columns for an anchored blanket node).
Eigen::MatrixXd blanketCovariance(const Linearized& graph, const std::vector<NodeId>& blanket) {
  const Eigen::MatrixXd covariance = graph.information.inverse();
  const auto size = static_cast<Eigen::Index>(3 * blanket.size());
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(size, size);
  auto at = [&](NodeId id) {
    return 3 * (std::find(graph.nodes.begin(), graph.nodes.end(), id) - graph.nodes.begin());
  };
  for (std::size_t i = 0; i < blanket.size(); ++i) {
    for (std::size_t j = 0; j < blanket.size(); ++j) {
      const auto a = at(blanket[i]), b = at(blanket[j]);
      if (a == static_cast<Eigen::Index>(3 * graph.nodes.size()) ||
          b == static_cast<Eigen::Index>(3 * graph.nodes.size())) {
        continue;  // the anchor
      }
      out.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * static_cast<Eigen::Index>(j)) =
          covariance.block<3, 3>(a, b);
    }
  }
  return out;
}

// replacementKl from the blanket's covariance alone equals the KL of the whole graph's
// linearized distributions (exact marginal against replacement) built densely, with the
// covariance anchored at node 0 (outside the blanket) or at a blanket node.
TEST(GaussianKl, ReplacementKlIsTheWholeGraphKl) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const PoseGraph graph = optimizedThinLoop(seed);
    std::vector<NodeId> removed;
    for (NodeId id = 10; id < 20; ++id) removed.push_back(id);
    const Marginal marginal = marginalizeNodes(graph, removed);
    const QuadraticModel dense = replacementModel(marginal, MarginalReplacement::kDense);
    const Linearized exact = withReplacement(graph, marginal, dense, 0);
    EXPECT_LT(exact.mean.norm(), 1e-7) << "the linearization point is the graph's minimum";
    // The blanket's covariance with node 0 held, and with blanket node 9 held instead.
    const Eigen::MatrixXd anchored_at_0 = blanketCovariance(exact, marginal.blanket);
    const Eigen::MatrixXd anchored_at_9 =
        blanketCovariance(withReplacement(graph, marginal, dense, 9), marginal.blanket);
    EXPECT_TRUE((anchored_at_9.topLeftCorner<3, 3>().isZero(0.0)));

    ChowLiuParams at_linearization;
    at_linearization.match_gradient = false;
    const std::vector<QuadraticModel> replacements{
        replacementModel(marginal, MarginalReplacement::kChowLiuTree),
        replacementModel(marginal, MarginalReplacement::kChowLiuTree, at_linearization),
        replacementModel(marginal, MarginalReplacement::kDelete)};
    for (const QuadraticModel& replacement : replacements) {
      const Linearized replaced = withReplacement(graph, marginal, replacement, 0);
      const double expected =
          gaussianKl(exact.mean, exact.information, replaced.mean, replaced.information);
      EXPECT_GT(expected, 1e-3);
      EXPECT_NEAR(replacementKl(anchored_at_0, marginal, replacement), expected, 1e-6 * expected)
          << seed;
      EXPECT_NEAR(replacementKl(anchored_at_9, marginal, replacement), expected, 1e-6 * expected)
          << seed;
    }
  }
}

// Deleting the constraints of a run of a chain cuts the graph in two: p1 is improper.
TEST(GaussianKl, InfiniteWhenDeletingDisconnectsTheGraph) {
  const PoseGraph chain = randomChainWithLoops(30, 3, 0);
  const Marginal marginal = marginalizeNodes(chain, {10, 11, 12, 13, 14});
  ASSERT_EQ(marginal.blanket, (std::vector<NodeId>{9, 15}));
  // The whole chain's covariance over the blanket, node 0 anchored.
  const std::vector<NodeId> nodes = chain.nodeIds();
  std::vector<Pose2> poses;
  for (NodeId id : nodes) poses.push_back(chain.pose(id));
  const QuadraticModel model = linearizeConstraints(constraintsOf(chain), nodes, poses);
  const Eigen::Index n = model.information.rows() - 3;
  const Eigen::MatrixXd covariance = model.information.bottomRightCorner(n, n).inverse();
  std::vector<Eigen::Index> rows;
  for (NodeId id : marginal.blanket) {
    for (int r = 0; r < 3; ++r) rows.push_back(3 * static_cast<Eigen::Index>(id - 1) + r);
  }
  const Eigen::MatrixXd blanket_covariance = covariance(rows, rows);
  EXPECT_EQ(replacementKl(blanket_covariance, marginal,
                          replacementModel(marginal, MarginalReplacement::kDelete)),
            std::numeric_limits<double>::infinity());
  // The tree of one edge holds the relative pose 9 -> 15 exactly.
  EXPECT_NEAR(replacementKl(blanket_covariance, marginal,
                            replacementModel(marginal, MarginalReplacement::kChowLiuTree)),
              0.0, 1e-9);
}

TEST(GaussianKl, BadInputThrows) {
  const Eigen::VectorXd zero3 = Eigen::VectorXd::Zero(3);
  const Eigen::MatrixXd identity3 = Eigen::MatrixXd::Identity(3, 3);
  EXPECT_THROW(gaussianKl(zero3, identity3, Eigen::VectorXd::Zero(2), identity3),
               std::invalid_argument);
  Eigen::MatrixXd singular = identity3;
  singular(2, 2) = 0.0;
  EXPECT_THROW(gaussianKl(zero3, identity3, zero3, singular), std::invalid_argument);
  EXPECT_THROW(klOfFactorChange(identity3, Eigen::MatrixXd::Identity(2, 2), zero3),
               std::invalid_argument);
  Eigen::VectorXd nan = zero3;
  nan(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(klOfFactorChange(identity3, identity3, nan), std::invalid_argument);
  Marginal marginal;
  marginal.blanket = {1};
  marginal.linearization_point = {Pose2::Zero()};
  marginal.information = identity3;
  marginal.gradient = zero3;
  QuadraticModel wrong{Eigen::MatrixXd::Identity(6, 6), Eigen::VectorXd::Zero(6), 0.0};
  EXPECT_THROW(replacementKl(identity3, marginal, wrong), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::core
