#include "rrr_graphslam/core/se2.h"

#include <cmath>

#include <Eigen/LU>

namespace rrr_graphslam::core {

double normalizeAngle(double angle_rad) {
  // remainder() maps to [-pi, pi]; fold -pi onto +pi so the interval is half-open.
  const double wrapped = std::remainder(angle_rad, 2.0 * M_PI);
  return wrapped <= -M_PI ? wrapped + 2.0 * M_PI : wrapped;
}

Eigen::Matrix2d rotation(double theta_rad) {
  const double c = std::cos(theta_rad);
  const double s = std::sin(theta_rad);
  Eigen::Matrix2d R;
  R << c, -s, s, c;
  return R;
}

Pose2 compose(const Pose2& a, const Pose2& b) {
  Pose2 out;
  out.head<2>() = a.head<2>() + rotation(a.z()) * b.head<2>();
  out.z() = normalizeAngle(a.z() + b.z());
  return out;
}

Pose2 inverse(const Pose2& a) {
  Pose2 out;
  out.head<2>() = -(rotation(a.z()).transpose() * a.head<2>());
  out.z() = normalizeAngle(-a.z());
  return out;
}

Pose2 between(const Pose2& a, const Pose2& b) {
  Pose2 out;
  out.head<2>() = rotation(a.z()).transpose() * (b.head<2>() - a.head<2>());
  out.z() = normalizeAngle(b.z() - a.z());
  return out;
}

Eigen::Matrix3d adjoint(const Pose2& T) {
  Eigen::Matrix3d Ad = Eigen::Matrix3d::Identity();
  Ad.topLeftCorner<2, 2>() = rotation(T.z());
  Ad(0, 2) = T.y();
  Ad(1, 2) = -T.x();
  return Ad;
}

Eigen::Matrix3d covarianceOfInverse(const Pose2& z, const Eigen::Matrix3d& covariance) {
  const Eigen::Matrix3d Ad = adjoint(z);
  return Ad * covariance * Ad.transpose();
}

Eigen::Matrix3d informationOfInverse(const Pose2& z, const Eigen::Matrix3d& information) {
  const Eigen::Matrix3d Ad_inv = adjoint(z).inverse();
  return Ad_inv.transpose() * information * Ad_inv;
}

Eigen::Vector3d edgeError(const Pose2& x_from, const Pose2& x_to, const Pose2& z) {
  return between(z, between(x_from, x_to));
}

EdgeLinearization linearizeEdge(const Pose2& x_from, const Pose2& x_to, const Pose2& z) {
  const Eigen::Matrix2d Ri = rotation(x_from.z());
  const Eigen::Matrix2d RzT = rotation(z.z()).transpose();
  const Eigen::Vector2d dt = x_to.head<2>() - x_from.head<2>();

  // d(Ri^T)/d(theta_i) = [[-s, c], [-c, -s]].
  const double c = std::cos(x_from.z());
  const double s = std::sin(x_from.z());
  Eigen::Matrix2d dRiT;
  dRiT << -s, c, -c, -s;

  EdgeLinearization lin;
  lin.error.head<2>() = RzT * (Ri.transpose() * dt - z.head<2>());
  lin.error.z() = normalizeAngle(x_to.z() - x_from.z() - z.z());

  const Eigen::Matrix2d RzT_RiT = RzT * Ri.transpose();
  lin.J_from.setZero();
  lin.J_from.topLeftCorner<2, 2>() = -RzT_RiT;
  lin.J_from.topRightCorner<2, 1>() = RzT * dRiT * dt;
  lin.J_from(2, 2) = -1.0;

  lin.J_to.setZero();
  lin.J_to.topLeftCorner<2, 2>() = RzT_RiT;
  lin.J_to(2, 2) = 1.0;
  return lin;
}

}  // namespace rrr_graphslam::core
