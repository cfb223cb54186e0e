#pragma once
// One simulated mapping session in a world: the robot starts at a random free place, visits
// random waypoints (or those of a given route) (free cells with clearance, each reached by the grid
// planner's path and pure pursuit), and records a scan and its odometry every 1 / scan_rate_hz
// seconds. Each session has its own odometry frame (a random SE(2) start pose) and its own date
// (session k starts k * session_gap_s after start_time_s). Everything random comes from (seed,
// session index): a session is the same whatever the number of sessions simulated with it, and the
// route does not depend on the noise settings.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/sim/carmen_writer.h"
#include "rrr_graphslam/sim/grid_planner.h"
#include "rrr_graphslam/sim/laser_simulator.h"
#include "rrr_graphslam/sim/odometry_model.h"
#include "rrr_graphslam/sim/path_follower.h"
#include "rrr_graphslam/sim/route.h"
#include "rrr_graphslam/sim/world.h"

namespace rrr_graphslam::sim {

struct SimulationParams {
  LaserParams laser;
  OdometryNoise odometry;
  PlannerParams planner;
  MotionParams motion;
  double scan_rate_hz = 5.0;  ///< Hz; scans (and odometry readings) per second (default 5)
  int waypoints = 8;          ///< random waypoints per session after the start (default 8)
  /// m; consecutive waypoints are at least this far apart in a straight line (default 3).
  double min_waypoint_separation_m = 3.0;
  std::size_t max_scans = 0;  ///< a session stops after this many scans (default 0: at its end)
  double start_time_s = 1700000000.0;  ///< s; session 0's first timestamp (default 1.7e9)
  double session_gap_s = 86400.0;      ///< s between session starts (default 86400, a day)
  /// m; each session's odometry frame puts its first pose uniformly in [-this, this]^2 with a
  /// uniform yaw (default 50).
  double odom_start_range_m = 50.0;
};

struct SimulatedSession {
  int index = 0;
  std::vector<double> stamps;         ///< s, one per scan
  std::vector<core::Pose2> truth;     ///< robot in the world frame
  std::vector<core::Pose2> odometry;  ///< robot in the session's odometry frame
  std::vector<std::vector<float>> ranges;
  std::vector<Eigen::Vector2d> waypoints_m;  ///< the start, then the waypoints, world frame
  double length_m = 0.0;                     ///< true distance driven

  /// The log records (odometry, velocities, scans).
  std::vector<LogRecord> logRecords(double period_s) const;
};

/// With a `route`, the session starts at its first waypoint and visits the others in order
/// (params.waypoints is then unused). Throws std::runtime_error when the world has no free place
/// with the planner's clearance to start from, and core::InputError naming the route's file and
/// waypoint when a waypoint has no traversable cell within 1 m or cannot be reached in this
/// session's world.
SimulatedSession simulateSession(const World& world, int index, const SimulationParams& params,
                                 std::uint64_t seed, const Route* route = nullptr);

}  // namespace rrr_graphslam::sim
