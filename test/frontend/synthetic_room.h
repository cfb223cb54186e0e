#pragma once
// A synthetic room for scan-matching tests: walls and boxes as segments, scans by ray casting.

#include <cmath>
#include <limits>
#include <vector>

#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/range_scan.h"

namespace rrr_graphslam::frontend::testing {

struct Segment {
  Eigen::Vector2d a;
  Eigen::Vector2d b;
};

/// A 12 m x 8 m room with an inner wall and two boxes (no symmetry a matcher could confuse).
inline std::vector<Segment> room() {
  std::vector<Segment> s = {{{0, 0}, {12, 0}},  {{12, 0}, {12, 8}},   {{12, 8}, {0, 8}},
                            {{0, 8}, {0, 0}},   {{4, 0}, {4, 3}},     {{7, 5}, {9, 5}},
                            {{9, 5}, {9, 6.5}}, {{9, 6.5}, {7, 6.5}}, {{7, 6.5}, {7, 5}},
                            {{2, 6}, {3, 7}}};
  return s;
}

/// A 360-beam scan from `pose` (laser at the robot origin), misses beyond max_range.
inline RangeScan castScan(const std::vector<Segment>& world, const core::Pose2& pose,
                          double max_range = 20.0) {
  RangeScan scan;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / 360;
  scan.max_range = max_range;
  for (int i = 0; i < 360; ++i) {
    const double a = pose.z() + scan.angle_min + i * scan.angle_increment;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double best = max_range;
    for (const Segment& s : world) {
      const Eigen::Vector2d e = s.b - s.a;
      const double denom = d.x() * e.y() - d.y() * e.x();
      if (std::abs(denom) < 1e-12) continue;
      const Eigen::Vector2d w = s.a - pose.head<2>();
      const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
      const double u = (w.x() * d.y() - w.y() * d.x()) / denom;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    scan.ranges.push_back(static_cast<float>(best));
  }
  return scan;
}

/// The robot's true pose k on a circle in the free part of the room (a lap is 105 scans).
inline core::Pose2 truthAt(int k) {
  const double a = 0.06 * k;
  return {7.5 + 1.5 * std::cos(a), 2.5 + 1.5 * std::sin(a), a + M_PI / 2};
}

/// Front-end parameters sized for this room: submaps of 20 scans (about a fifth of a lap), loop
/// searches every second node from 15 nodes back, one search thread (deterministic tests).
inline LaserSlamParams roomSizedParams() {
  LaserSlamParams p;
  p.local.submap.scans_per_submap = 20;
  p.loops.min_node_separation = 15;
  p.loops.search_every_n_nodes = 2;
  p.loops.search_min_points = 60;
  p.loops.threads = 1;
  return p;
}

/// Drives scans first .. first + scans - 1 of the circle, 0.1 s apart from t0; the odometry is
/// the truth seen from `odom_frame`.
inline void drive(LaserSlam& slam, const core::Pose2& odom_frame, int scans, double t0,
                  int first = 0) {
  for (int k = first; k < first + scans; ++k) {
    RangeScan scan = castScan(room(), truthAt(k));
    scan.timestamp = t0 + 0.1 * k;
    slam.addScan(scan, core::compose(odom_frame, truthAt(k)));
  }
}

}  // namespace rrr_graphslam::frontend::testing
