#pragma once
// Where a robot and its laser can be. Beyond these a pose cannot be a robot's (single-precision
// grid coordinates lose centimetres beyond 1e5-1e6 m): live scans (LocalSlam) and loaded maps
// (map_file.h) placing a robot or a laser further are refused before MRPT's grids would try to
// grow to them.

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

inline constexpr double kMaxCoordinate = 1e6;     ///< m, |x| and |y| of a robot pose
inline constexpr double kMaxLaserOffset = 100.0;  ///< m, the laser from the robot

/// A laser pose in the robot frame that a live scan may have: finite, within kMaxLaserOffset.
inline bool plausibleLaserPose(const core::Pose2& laser_in_robot) {
  return laser_in_robot.allFinite() && laser_in_robot.head<2>().norm() <= kMaxLaserOffset;
}

}  // namespace rrr_graphslam::frontend
