#include "rrr_graphslam/core/odometry_noise.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace rrr_graphslam::core {

void compositionJacobians(const Pose2& x, const Pose2& u, Eigen::Matrix3d& A, Eigen::Matrix3d& B) {
  const double c = std::cos(x.z()), s = std::sin(x.z());
  A << 1.0, 0.0, -s * u.x() - c * u.y(),  //
      0.0, 1.0, c * u.x() - s * u.y(),    //
      0.0, 0.0, 1.0;
  B << c, -s, 0.0,  //
      s, c, 0.0,    //
      0.0, 0.0, 1.0;
}

std::optional<Eigen::Matrix3d> stepCovarianceFromAbsolute(
    const Pose2& previous, const Eigen::Matrix3d& previous_covariance, const Pose2& current,
    const Eigen::Matrix3d& current_covariance) {
  Eigen::Matrix3d A, B;
  compositionJacobians(previous, between(previous, current), A, B);
  const Eigen::Matrix3d added = current_covariance - A * previous_covariance * A.transpose();
  const Eigen::Matrix3d B_inverse = B.transpose();  // a rotation
  Eigen::Matrix3d step = B_inverse * added * B_inverse.transpose();
  step = 0.5 * (step + step.transpose());
  if (!step.allFinite()) return std::nullopt;
  const Eigen::LLT<Eigen::Matrix3d> llt(step);
  if (llt.info() != Eigen::Success) return std::nullopt;
  // Definite, and not merely by rounding: no Cholesky pivot below 1e-6 of the largest (the units
  // mix m^2 and rad^2: a guard against rounding, not a physical floor).
  const Eigen::Vector3d d = llt.matrixLLT().diagonal();
  if (d.minCoeff() <= 1e-6 * d.maxCoeff()) return std::nullopt;
  return step;
}

Eigen::Matrix3d stepCovarianceFromMotion(const Pose2& step, const MotionNoise& noise) {
  const double d = std::max(std::hypot(step.x(), step.y()), noise.min_travel_m);
  const double turned = std::max(std::abs(normalizeAngle(step.z())), noise.min_rotation_rad);
  const Eigen::Vector3d sigma(noise.stddev.x() * d, noise.stddev.y() * d,
                              noise.stddev.z() * (turned + d));
  return sigma.cwiseAbs2().asDiagonal();
}

}  // namespace rrr_graphslam::core
