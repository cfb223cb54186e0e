#include "rrr_graphslam/sim/carmen_writer.h"

#include <iomanip>
#include <sstream>

#include "rrr_graphslam/core/atomic_file.h"

namespace rrr_graphslam::sim {
namespace {

constexpr const char* kHost = "rrr_simulate";

}  // namespace

void writeCarmenLog(const std::string& path, const std::vector<LogRecord>& records,
                    const LaserParams& laser, const std::string& comment) {
  core::writeFileAtomically(path, [&](std::ostream& out) {
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);) out << "# " << line << '\n';
    out << "# ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp\n"
        << "# ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy "
           "remission_mode num_readings [range_readings] num_remissions laser_x laser_y "
           "laser_theta robot_x robot_y robot_theta tv rv forward_safety_dist side_safety_dist "
           "turn_axis ipc_timestamp ipc_hostname logger_timestamp\n"
        << std::fixed;
    const double fov = (laser.beam_count - 1) * laser.angle_increment_rad;
    for (const LogRecord& r : records) {
      const core::Pose2 laser_pose = core::compose(r.odom_pose, laser.laser_in_robot);
      const double laser_yaw = core::normalizeAngle(laser_pose.z());
      out << std::setprecision(6) << "ODOM " << r.odom_pose.x() << ' ' << r.odom_pose.y() << ' '
          << r.odom_pose.z() << ' ' << r.speed_mps << ' ' << r.turn_rate_radps << " 0.000000 "
          << r.timestamp << ' ' << kHost << ' ' << r.timestamp << '\n';
      out << "ROBOTLASER1 0 " << laser.angle_min_rad << ' ' << fov << ' '
          << laser.angle_increment_rad << ' ' << laser.max_range_m << ' ' << laser.range_stddev_m
          << " 0 " << r.ranges.size() << std::setprecision(3);
      for (const float range : r.ranges) out << ' ' << range;
      out << " 0" << std::setprecision(6) << ' ' << laser_pose.x() << ' ' << laser_pose.y() << ' '
          << laser_yaw << ' ' << r.odom_pose.x() << ' ' << r.odom_pose.y() << ' ' << r.odom_pose.z()
          << ' ' << r.speed_mps << ' ' << r.turn_rate_radps << " 0.000000 0.000000 0.000000 "
          << r.timestamp << ' ' << kHost << ' ' << r.timestamp << '\n';
    }
  });
}

}  // namespace rrr_graphslam::sim
