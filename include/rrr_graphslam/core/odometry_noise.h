#pragma once
// The information of one odometry step between two keyframes.
//
// A nav_msgs/Odometry pose covariance is the covariance of the absolute pose, which grows as the
// robot dead-reckons; the step's own covariance follows from two of them: with
// x_k = x_{k-1} (+) u, Sigma_k = A Sigma_{k-1} A^T + B Sigma_u B^T (A, B the Jacobians of the
// composition), so Sigma_u = B^-1 (Sigma_k - A Sigma_{k-1} A^T) B^-T. Drivers that publish a
// constant covariance make that difference zero or indefinite; the step's noise then comes from
// a motion model instead: standard deviations per metre driven and per radian turned.

#include <optional>

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

/// Sigma_u of the step from `previous` to `current` given their absolute covariances; nullopt
/// when Sigma_k - A Sigma_{k-1} A^T is not positive definite (the covariances are not those of
/// dead reckoning) or not finite.
std::optional<Eigen::Matrix3d> stepCovarianceFromAbsolute(
    const Pose2& previous, const Eigen::Matrix3d& previous_covariance, const Pose2& current,
    const Eigen::Matrix3d& current_covariance);

struct MotionNoise {
  /// Standard deviations: x and y in metres per metre driven, yaw in radians per radian turned
  /// and per metre driven.
  Eigen::Vector3d stddev{0.05, 0.05, 0.02};
  /// The step counts at least this long and this much turned (a keyframe's thresholds), so a
  /// step in place still has a finite information.
  double min_travel_m = 0.5;
  double min_rotation_rad = 0.5;
};

/// Sigma_u of a step from the motion model: sigma_xy = stddev_xy * d and sigma_yaw = stddev_yaw *
/// (|dtheta| + d), with d and |dtheta| at least the minima.
Eigen::Matrix3d stepCovarianceFromMotion(const Pose2& step, const MotionNoise& noise);

/// The composition's Jacobians: x (+) u with respect to x (A) and to u (B).
void compositionJacobians(const Pose2& x, const Pose2& u, Eigen::Matrix3d& A, Eigen::Matrix3d& B);

}  // namespace rrr_graphslam::core
