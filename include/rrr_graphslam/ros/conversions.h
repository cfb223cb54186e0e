#pragma once
// ROS messages <-> core types, free functions only. Conversions that can meet bad data throw
// std::invalid_argument naming the message field; the caller adds the topic.

#include <cstdint>
#include <optional>
#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Pose2D.h>
#include <geometry_msgs/Transform.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/LaserScan.h>
#include <Eigen/Core>
#include <boost/array.hpp>

#include "rrr_graphslam/LoopClosureDecision.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/range_scan.h"
#include "rrr_graphslam/rrr/online_rrr.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace rrr_graphslam::ros_adapter {

core::Pose2 toPose2(const geometry_msgs::Pose2D& pose);

/// Row-major 3x3 (x, y, theta), as in LoopCandidate and PoseGraphEdge. Not checked here: the
/// core refuses non-finite or non-positive-definite information with the field named.
Eigen::Matrix3d toInformation(const boost::array<double, 9>& row_major);

/// Planar pose of a 3D pose: x, y and yaw. Throws for a non-finite position or a quaternion
/// that is not of unit length ("position", "orientation").
core::Pose2 toPose2(const geometry_msgs::Pose& pose);

/// The (x, y, yaw) block of a 6x6 row-major pose covariance (nav_msgs/Odometry); std::nullopt
/// when the block is all zero (drivers that publish no covariance).
std::optional<Eigen::Matrix3d> planarCovariance(const boost::array<double, 36>& covariance);

geometry_msgs::Pose toPoseMsg(const core::Pose2& pose);
geometry_msgs::Transform toTransformMsg(const core::Pose2& pose);

/// Planar pose of a transform (translation x, y and yaw); throws like toPose2(Pose).
core::Pose2 toPose2(const geometry_msgs::Transform& transform);

/// A LaserScan as the front end reads it. Throws for an empty or one-beam scan, a non-positive
/// or non-finite angle_increment, range_max or angle_min ("ranges", "angle_increment", ...).
/// Readings that are NaN, +inf or above range_max are misses; below range_min they are dropped.
frontend::RangeScan toRangeScan(const sensor_msgs::LaserScan& msg,
                                const core::Pose2& laser_in_robot);

/// nav_msgs/OccupancyGrid of an MRPT grid: 0..100 occupancy, -1 for cells never observed.
void toOccupancyGridMsg(const mrpt::maps::COccupancyGridMap2D& grid, nav_msgs::OccupancyGrid& msg);

/// LoopClosureDecision's verdict constant.
std::uint8_t toVerdictMsg(rrr::Verdict verdict);

/// A verdict change as ~decisions carries it. Throws std::invalid_argument when a node id does
/// not fit the message's uint32 ("from_id", "to_id"): a truncated id would name another node.
LoopClosureDecision toDecisionMsg(const rrr::DecisionChange& change, const std::string& frame,
                                  const ros::Time& stamp);

}  // namespace rrr_graphslam::ros_adapter
