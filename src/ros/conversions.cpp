#include "rrr_graphslam/ros/conversions.h"

#include <limits>
#include <string>

#include <mrpt/maps/COccupancyGridMap2D.h>

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

core::Pose2 toPose2(const geometry_msgs::Transform& transform) {
  geometry_msgs::Pose pose;
  pose.position.x = transform.translation.x;
  pose.position.y = transform.translation.y;
  pose.position.z = transform.translation.z;
  pose.orientation = transform.rotation;
  return toPose2(pose);
}

frontend::RangeScan toRangeScan(const sensor_msgs::LaserScan& msg,
                                const core::Pose2& laser_in_robot) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (msg.ranges.size() < 2) {
    throw std::invalid_argument("ranges holds " + std::to_string(msg.ranges.size()) +
                                " readings; a scan needs at least 2");
  }
  if (!positive(msg.angle_increment)) {
    throw std::invalid_argument("angle_increment must be positive, got " +
                                std::to_string(msg.angle_increment));
  }
  if (!positive(msg.range_max)) {
    throw std::invalid_argument("range_max must be positive, got " + std::to_string(msg.range_max));
  }
  if (!std::isfinite(msg.angle_min)) throw std::invalid_argument("angle_min is not finite");
  // One reading per angle_increment from angle_min to angle_max; drivers differ by one at the end.
  const double span = (static_cast<double>(msg.angle_max) - msg.angle_min) / msg.angle_increment;
  const auto count = static_cast<double>(msg.ranges.size());
  if (!std::isfinite(span) || std::abs(span + 1.0 - count) > 1.5) {
    throw std::invalid_argument(
        "ranges holds " + std::to_string(msg.ranges.size()) + " readings, but angle_min " +
        std::to_string(msg.angle_min) + " to angle_max " + std::to_string(msg.angle_max) + " at " +
        std::to_string(msg.angle_increment) + " rad spans " + std::to_string(span + 1.0));
  }
  frontend::RangeScan scan;
  scan.timestamp = msg.header.stamp.toSec();
  scan.angle_min = msg.angle_min;
  scan.angle_increment = msg.angle_increment;
  scan.max_range = msg.range_max;
  scan.laser_in_robot = laser_in_robot;
  scan.ranges.reserve(msg.ranges.size());
  for (const float r : msg.ranges) {
    // Below range_min: no information (the matcher drops readings under its min_range).
    scan.ranges.push_back(std::isnan(r)       ? std::numeric_limits<float>::infinity()
                          : r < msg.range_min ? 0.0F
                                              : r);
  }
  return scan;
}

void toOccupancyGridMsg(const mrpt::maps::COccupancyGridMap2D& grid, nav_msgs::OccupancyGrid& msg) {
  msg.info.resolution = grid.getResolution();
  msg.info.width = grid.getSizeX();
  msg.info.height = grid.getSizeY();
  msg.info.origin.position.x = grid.getXMin();
  msg.info.origin.position.y = grid.getYMin();
  msg.info.origin.orientation.w = 1.0;
  const auto& raw = grid.getRawMap();
  msg.data.resize(raw.size());
  for (std::size_t k = 0; k < raw.size(); ++k) {
    // MRPT cells: log-odds of being free; 0 = never observed. Both grids are rows of x from the
    // lower-left corner.
    msg.data[k] = raw[k] == 0
                      ? std::int8_t{-1}
                      : static_cast<std::int8_t>(std::lround(
                            100.0F * (1.0F - mrpt::maps::COccupancyGridMap2D::l2p(raw[k]))));
  }
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

LoopClosureDecision toDecisionMsg(const rrr::DecisionChange& change, const std::string& frame,
                                  const ros::Time& stamp) {
  auto id32 = [](const char* field, rrr::OnlineRrr::NodeId id) {
    if (id > std::numeric_limits<std::uint32_t>::max()) {
      throw std::invalid_argument(std::string(field) + " " + std::to_string(id) +
                                  " does not fit LoopClosureDecision's uint32");
    }
    return static_cast<std::uint32_t>(id);
  };
  LoopClosureDecision msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame;
  msg.from_id = id32("from_id", change.from);
  msg.to_id = id32("to_id", change.to);
  msg.cluster = change.cluster;
  msg.verdict = toVerdictMsg(change.verdict);
  msg.previous_verdict = toVerdictMsg(change.previous);
  msg.reason = change.reason;
  msg.candidate = static_cast<std::uint32_t>(change.candidate);
  return msg;
}

}  // namespace rrr_graphslam::ros_adapter
