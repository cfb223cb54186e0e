#pragma once
// The exact marginal of removed nodes kept as one factor over their Markov blanket (GLC's dense
// factor: Carlevaris-Bianco, Kaess, Eustice, "Generic Node Removal for Factor-Graph SLAM",
// T-RO 2014, Sec. III-C, root-shifted as in Sec. III-D), the `dense` replacement of lifelong
// trimming beside the Chow-Liu tree (chow_liu.h) and deletion.
//
// Form. A factor over nodes r (the root) and i_1 .. i_k holds, for each i_a, the relative pose
// y_a of i_a in r's frame at the linearization point, and a Gaussian over the stacked edge errors
// e_a(x) = edgeError(x_r, x_{i_a}, y_a) (the optimizer's error, se2.h):
//   chi2(x) = (e(x) - mean)^T Omega (e(x) - mean) + chi2_offset.
// Only relative poses enter, so the factor is exactly invariant to a rigid motion of the whole
// graph (the gauge), not only to first order: a map moved to another frame, a session placed
// again, keep its meaning. Its residual has 3k = 3(|B| - 1) rows, as many as a spanning tree of
// |B| - 1 relative-pose constraints over the same nodes.
//
// From a marginal (marginalization.h's denseFactors: information Lambda, gradient g, chi2 c at
// x0, additive perturbation dx): each connected piece of the blanket becomes one factor, rooted at
// its first node. The marginal is gauge invariant, so holding the root at x0 loses nothing; the
// others' perturbations map to the errors by the edges' Jacobians, de_a = J_to,a dx_a (J_to
// invertible), so over the errors the quadratic is c + 2 h^T e + e^T Omega e with Omega = J^-T
// Lambda_oo J^-1 and h = J^-T g_o. Completing the square: mean = -Omega^-1 h and chi2_offset = c -
// h^T Omega^-1 h >= 0 (the removed constraints' chi2 minimized over both M and the blanket's
// shape). Linearized at x0 the factor gives back the marginal's information, gradient and chi2
// exactly (test_dense_factor): KL(marginal || dense) = 0 at the trim.
//
// Why the offset is kept: with it, the factor's chi2 is the removed constraints' (minimized over
// M) to second order, so a graph's chi2 and its degrees of freedom count keep their meaning for
// RRR's tests after a trim.

#include <string>
#include <vector>

#include <Eigen/Core>

#include <mrpt/graphs/TNodeID.h>
#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

/// A dense Gaussian factor over the relative poses of `nodes[1..]` from `nodes[0]`.
struct DenseFactor {
  std::vector<mrpt::graphs::TNodeID> nodes;  ///< root first, at least two, distinct
  std::vector<Pose2> measurements;           ///< y_a: pose of nodes[a + 1] in the root's frame
  Eigen::VectorXd mean;                      ///< the errors' mean, 3(n - 1)
  Eigen::MatrixXd information;               ///< Omega over the stacked errors, 3(n - 1) square
  double chi2_offset = 0.0;                  ///< chi2 at the factor's minimum (>= 0)

  std::size_t numNodes() const { return nodes.size(); }
  /// Rows of the residual: 3(n - 1).
  int dimension() const { return 3 * static_cast<int>(nodes.size() - 1); }
};

/// What is wrong with `factor` (empty if nothing): fewer than two nodes, a node twice, sizes
/// that do not match, a non-finite entry, an information matrix that is not symmetric positive
/// definite, a negative offset.
std::string denseFactorProblem(const DenseFactor& factor);

/// The factor's Gauss-Newton model at `poses` (one per factor node, in its order): information
/// J^T Omega J over the nodes (3n square, node order), gradient J^T Omega r and chi2 r^T Omega r
/// + chi2_offset, with r = e(x) - mean and J = dr/dx (additive perturbations, as
/// linearized_constraints.h).
struct DenseFactorLinearization {
  Eigen::MatrixXd information;
  Eigen::VectorXd gradient;
  double chi2 = 0.0;
};
DenseFactorLinearization linearize(const DenseFactor& factor, const std::vector<Pose2>& poses);

/// chi2 of the factor at `poses` (its node order).
double denseFactorChi2(const DenseFactor& factor, const std::vector<Pose2>& poses);

}  // namespace rrr_graphslam::core
