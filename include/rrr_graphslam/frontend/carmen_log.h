#pragma once
// CARMEN laser logs (FLASER, ROBOTLASER1; plain or .gz), the logs of the Radish and slamevaluation
// collections. The C++ twin of src/rrr_graphslam/carmen.py: same conventions, and the Python tests
// read the same fixture.
//
// Conventions the logs leave implicit:
// - FLASER has no angle fields: the beams span 180 degrees from -90 degrees, pi/n apart for an even
//   count (180, 360 readings) and pi/(n-1) for an odd one (181, 361).
// - "No return" is written as the sensor's maximum range; FLASER states no maximum, so the log's
//   largest reading is taken as it. Readings at or above max_range are misses.
// - The timestamp is the ipc_timestamp field (the one relations files use). It may go backwards
//   (Intel): records keep log order.
// Other message types (ODOM, PARAM, SYNC, TRUEPOS, ...) are skipped: the scans carry the odometry.

#include <cstddef>
#include <string>
#include <vector>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

struct LaserRecord {
  double timestamp = 0.0;        ///< ipc_timestamp, s
  double angle_min = 0.0;        ///< rad, first beam in the laser frame
  double angle_increment = 0.0;  ///< rad
  double max_range = 0.0;        ///< m; readings at or above it are misses
  std::vector<float> ranges;
  core::Pose2 laser_pose = core::Pose2::Zero();  ///< laser in the odometry frame
  core::Pose2 odom_pose = core::Pose2::Zero();   ///< robot in the odometry frame
  std::size_t line = 0;                          ///< 1-based line in the log

  /// The laser in the robot frame.
  core::Pose2 laserInRobot() const { return core::between(odom_pose, laser_pose); }
};

struct CarmenLog {
  std::string path;
  std::vector<LaserRecord> scans;  ///< log order
};

/// Throws core::InputError (file:line) for a file that cannot be read, a malformed FLASER or
/// ROBOTLASER1 line (field count, non-numeric or non-finite field, non-positive resolution) or a
/// log without scans.
CarmenLog readCarmenLog(const std::string& path);

/// The FLASER angular increment for n readings (see above).
double flaserIncrement(std::size_t n);

}  // namespace rrr_graphslam::frontend
