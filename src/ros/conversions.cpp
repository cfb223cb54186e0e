#include "rrr_graphslam/ros/conversions.h"

#include <cmath>
#include <stdexcept>

#include <tf2/LinearMath/Quaternion.h>
#include <tf2/utils.h>

#include "rrr_graphslam/LoopClosureDecision.h"

namespace rrr_graphslam::ros_adapter {

core::Pose2 toPose2(const geometry_msgs::Pose2D& pose) { return {pose.x, pose.y, pose.theta}; }

Eigen::Matrix3d toInformation(const boost::array<double, 9>& row_major) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = row_major[static_cast<std::size_t>(3 * r + c)];
  }
  return m;
}

core::Pose2 toPose2(const geometry_msgs::Pose& pose) {
  const auto& p = pose.position;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
    throw std::invalid_argument("position is not finite");
  }
  const auto& q = pose.orientation;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-3) {
    throw std::invalid_argument("orientation is not a unit quaternion (norm " +
                                std::to_string(norm) + ")");
  }
  return {p.x, p.y, tf2::getYaw(tf2::Quaternion(q.x, q.y, q.z, q.w))};
}

std::optional<Eigen::Matrix3d> planarCovariance(const boost::array<double, 36>& covariance) {
  constexpr int kAxes[3] = {0, 1, 5};  // x, y, yaw in (x, y, z, roll, pitch, yaw)
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      m(r, c) = covariance[static_cast<std::size_t>(6 * kAxes[r] + kAxes[c])];
  }
  if (m.isZero(0.0)) return std::nullopt;
  return m;
}

geometry_msgs::Pose toPoseMsg(const core::Pose2& pose) {
  geometry_msgs::Pose msg;
  msg.position.x = pose[0];
  msg.position.y = pose[1];
  tf2::Quaternion q;
  q.setRPY(0.0, 0.0, pose[2]);
  msg.orientation.x = q.x();
  msg.orientation.y = q.y();
  msg.orientation.z = q.z();
  msg.orientation.w = q.w();
  return msg;
}

geometry_msgs::Transform toTransformMsg(const core::Pose2& pose) {
  const geometry_msgs::Pose p = toPoseMsg(pose);
  geometry_msgs::Transform t;
  t.translation.x = p.position.x;
  t.translation.y = p.position.y;
  t.rotation = p.orientation;
  return t;
}

std::uint8_t toVerdictMsg(rrr::Verdict verdict) {
  switch (verdict) {
    case rrr::Verdict::kAccepted:
      return LoopClosureDecision::ACCEPTED;
    case rrr::Verdict::kRejected:
      return LoopClosureDecision::REJECTED;
    case rrr::Verdict::kPending:
      break;
  }
  return LoopClosureDecision::PENDING;
}

}  // namespace rrr_graphslam::ros_adapter
