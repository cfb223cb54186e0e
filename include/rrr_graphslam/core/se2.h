#pragma once
// SE(2) helpers for pose-graph optimization. Poses are Eigen::Vector3d (x_m, y_m, theta_rad).
//
// The edge error follows g2o's EdgeSE2 so that chi-square values are comparable with g2o:
//   e = t2v(Z^-1 * (X_from^-1 * X_to)),
// and the state is updated additively on (x, y, theta) with theta wrapped to (-pi, pi].
// The analytic Jacobians below are those of Grisetti et al., "A tutorial on graph-based SLAM"
// (2010), checked against numerical differentiation in test/core/test_se2.cpp.

#include <Eigen/Core>

namespace rrr_graphslam::core {

using Pose2 = Eigen::Vector3d;

/// Wraps an angle to (-pi, pi].
double normalizeAngle(double angle_rad);

/// Rotation matrix of angle theta_rad.
Eigen::Matrix2d rotation(double theta_rad);

/// a * b (b expressed in a's frame, result in the world frame).
Pose2 compose(const Pose2& a, const Pose2& b);

/// a^-1.
Pose2 inverse(const Pose2& a);

/// a^-1 * b: the pose of b in a's frame.
Pose2 between(const Pose2& a, const Pose2& b);

/// Adjoint of SE(2) acting on (x, y, theta) tangent vectors: T * exp(xi) = exp(Ad(T) xi) * T.
Eigen::Matrix3d adjoint(const Pose2& T);

/// Covariance of z^-1 for a measurement with noise on the right, z Exp(n), cov(n) = covariance:
/// (z Exp(n))^-1 = z^-1 Exp(-Ad(z) n), so the reversed measurement's is Ad(z) C Ad(z)^T.
Eigen::Matrix3d covarianceOfInverse(const Pose2& z, const Eigen::Matrix3d& covariance);
/// The same in information form: Ad(z)^-T Omega Ad(z)^-1.
Eigen::Matrix3d informationOfInverse(const Pose2& z, const Eigen::Matrix3d& information);

/// Error of a relative-pose measurement z (pose of `to` in `from`'s frame).
Eigen::Vector3d edgeError(const Pose2& x_from, const Pose2& x_to, const Pose2& z);

/// Error and Jacobians with respect to the additive perturbation of each end.
struct EdgeLinearization {
  Eigen::Vector3d error;
  Eigen::Matrix3d J_from;  ///< d error / d x_from
  Eigen::Matrix3d J_to;    ///< d error / d x_to
};

EdgeLinearization linearizeEdge(const Pose2& x_from, const Pose2& x_to, const Pose2& z);

}  // namespace rrr_graphslam::core
