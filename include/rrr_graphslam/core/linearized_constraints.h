#pragma once
// Relative-pose constraints outside an optimizer, and their quadratic model at a linearization
// point: what marginalization (marginalization.h), Chow-Liu sparsification (chow_liu.h) and the
// KL divergences that compare them (gaussian_kl.h) work on.
//
// The error, its Jacobians and the additive state update are the optimizer's (se2.h's
// linearizeEdge, g2o's EdgeSE2), so a constraint here means to Optimizer::addConstraint exactly
// what it means to these functions. With dx the additive perturbation of the poses (angles
// wrapped), a set of constraints is, to second order,
//   chi2(x0 + dx) ~ chi2_at_linearization + 2 gradient^T dx + dx^T information dx,
// with information = sum J^T Omega J and gradient = sum J^T Omega e: a Gaussian in information
// form, exp(-chi2 / 2), with a flat direction wherever nothing constrains the poses (the gauge).

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/dense_factor.h"
#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

using NodeId = PoseGraph::NodeId;

/// A relative-pose constraint, error edgeError(x_from, x_to, measurement).
struct PoseConstraint {
  NodeId from;
  NodeId to;
  Pose2 measurement;            ///< pose of `to` in `from`'s frame (m, m, rad)
  Eigen::Matrix3d information;  ///< inverse covariance of the measurement's error
};

/// The quadratic model of a set of constraints over an ordered list of nodes (3 rows per node,
/// x, y, theta, in the list's order), at the poses given for them.
struct QuadraticModel {
  Eigen::MatrixXd information;         ///< sum J^T Omega J
  Eigen::VectorXd gradient;            ///< sum J^T Omega e (half the gradient of chi2)
  double chi2_at_linearization = 0.0;  ///< sum e^T Omega e at the poses given
};

/// The quadratic model of `constraints` (each joining two of `nodes`) at `poses` (one per node,
/// in `nodes` order), dense. Throws std::invalid_argument for a constraint with an end not in
/// `nodes` or for mismatched sizes.
QuadraticModel linearizeConstraints(const std::vector<PoseConstraint>& constraints,
                                    const std::vector<NodeId>& nodes,
                                    const std::vector<Pose2>& poses);

/// The same with dense factors (dense_factor.h) over `nodes` added to the model.
QuadraticModel linearizeConstraints(const std::vector<PoseConstraint>& constraints,
                                    const std::vector<DenseFactor>& factors,
                                    const std::vector<NodeId>& nodes,
                                    const std::vector<Pose2>& poses);

/// The constraints of `graph` in edge order (constraint k is edge k).
std::vector<PoseConstraint> constraintsOf(const PoseGraph& graph);

/// x - x0 on (x, y, theta), the angle wrapped: the additive perturbation the quadratic models are
/// written in, for poses listed in the same order.
Eigen::VectorXd perturbation(const std::vector<Pose2>& x, const std::vector<Pose2>& x0);

}  // namespace rrr_graphslam::core
