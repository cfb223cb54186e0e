#pragma once
// Laser scans of a world by ray casting with MRPT's COccupancyGridMap2D::laserScanSimulator,
// with the beam layout and range noise of a real sensor. The default is a SICK LMS 200 as in the
// Intel and ACES logs: 181 beams over 180 degrees, 1 degree apart, counter-clockwise from the
// robot's right. A beam that hits nothing within max_range_m reads max_range_m (CARMEN's "no
// return"); the others get Gaussian noise and stay below max_range_m.

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/sim/world.h"

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace rrr_graphslam::sim {

struct LaserParams {
  int beam_count = 181;                              ///< beams per scan (default 181)
  double angle_min_rad = -M_PI / 2;                  ///< first beam, laser frame (default -pi/2)
  double angle_increment_rad = M_PI / 180;           ///< between beams (default 1 degree)
  double max_range_m = 30.0;                         ///< m (default 30)
  double range_stddev_m = 0.01;                      ///< m; Gaussian range noise (default 0.01)
  core::Pose2 laser_in_robot = core::Pose2::Zero();  ///< mounting pose (default: the origin)
  /// m; rays are cast in a copy of the world at least this fine (default 0.01: MRPT returns
  /// ranges in steps of 0.8 of its cells), unless that copy would exceed 64 million cells.
  double ray_cast_resolution_m = 0.01;
};

class LaserSimulator {
 public:
  LaserSimulator(const World& world, const LaserParams& params);
  ~LaserSimulator();
  LaserSimulator(const LaserSimulator&) = delete;
  LaserSimulator& operator=(const LaserSimulator&) = delete;

  /// The ranges (m) seen from the robot at `robot_in_world`; noise-free when rng is null.
  std::vector<float> scan(const core::Pose2& robot_in_world, std::mt19937_64* rng) const;
  const LaserParams& params() const { return params_; }

 private:
  LaserParams params_;
  Eigen::Vector2d origin_m_;
  std::unique_ptr<mrpt::maps::COccupancyGridMap2D> grid_;  // the world in its own frame
};

}  // namespace rrr_graphslam::sim
