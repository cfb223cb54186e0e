#pragma once
// Where a robot and its laser can be. Beyond these a pose cannot be a robot's (single-precision
// grid coordinates lose centimetres beyond 1e5-1e6 m): live scans (LocalSlam) and loaded maps
// (map_file.h) placing a robot or a laser further are refused before MRPT's grids would try to
// grow to them.

namespace rrr_graphslam::frontend {

inline constexpr double kMaxCoordinate = 1e6;     ///< m, |x| and |y| of a robot pose
inline constexpr double kMaxLaserOffset = 100.0;  ///< m, the laser from the robot

}  // namespace rrr_graphslam::frontend
