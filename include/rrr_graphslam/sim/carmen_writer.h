#pragma once
// Simulated sessions as CARMEN logs: per scan an ODOM line and a ROBOTLASER1 line (which states
// its own angles and maximum range, so no reader has to guess them), both at the robot's odometry
// pose, as frontend::readCarmenLog and src/rrr_graphslam/carmen.py read them.

#include <string>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/sim/laser_simulator.h"

namespace rrr_graphslam::sim {

struct LogRecord {
  double timestamp = 0.0;                       ///< s; written as ipc and logger timestamp
  core::Pose2 odom_pose = core::Pose2::Zero();  ///< robot in its odometry frame
  double speed_mps = 0.0;                       ///< translational velocity (tv)
  double turn_rate_radps = 0.0;                 ///< rotational velocity (rv)
  std::vector<float> ranges;                    ///< m, LaserParams' layout
};

/// Writes the log atomically; `comment` becomes the header's '#' lines. Throws
/// std::runtime_error naming the file on failure.
void writeCarmenLog(const std::string& path, const std::vector<LogRecord>& records,
                    const LaserParams& laser, const std::string& comment);

}  // namespace rrr_graphslam::sim
