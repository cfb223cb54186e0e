#pragma once
// A given route: the places a session visits in order, instead of random waypoints
// (rrr_simulate --route). The file is YAML:
//
//   waypoints:
//     - [0.0, -18.6]   # the start, world frame, m
//     - [9.0, -18.8]
//
// Each session plans its way between consecutive waypoints in its own world; a waypoint that a
// change has covered moves to the nearest traversable cell within 1 m.

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rrr_graphslam::sim {

struct Route {
  std::string path;
  std::vector<Eigen::Vector2d> waypoints_m;  ///< world frame; the first is the start
  std::vector<std::size_t> lines;            ///< 1-based line of each waypoint
};

/// Throws core::InputError naming the file, the line and the waypoint for a malformed or
/// non-finite point, and for fewer than 2 waypoints.
Route readRoute(const std::string& path);

}  // namespace rrr_graphslam::sim
