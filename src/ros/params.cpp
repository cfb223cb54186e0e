#include "rrr_graphslam/ros/params.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace rrr_graphslam::ros_adapter {
namespace {

class ParamReader {
 public:
  explicit ParamReader(const ros::NodeHandle& nh) : nh_(nh) {}

  // Reads `name` if set (keeps the default otherwise); `ok` checks the value.
  template <class T>
  void read(const std::string& name, T& value, const std::function<bool(const T&)>& ok,
            const char* requirement) {
    if (nh_.hasParam(name)) {
      if (!nh_.getParam(name, value)) fail(name, "has the wrong type");
    }
    if (!ok(value)) {
      std::ostringstream what;
      what << "must be " << requirement << ", got " << value;
      fail(name, what.str());
    }
  }

  // Reads `name` if set; the type must match (a number for an int or double, true/false for a
  // bool); the range is checked by the caller.
  template <class T>
  void read(const std::string& name, T& value) {
    if (nh_.hasParam(name) && !nh_.getParam(name, value)) fail(name, "has the wrong type");
  }

  void positive(const std::string& name, double& value) {
    read<double>(
        name, value, [](const double& v) { return std::isfinite(v) && v > 0.0; }, "positive");
  }
  void positive(const std::string& name, int& value) {
    read<int>(
        name, value, [](const int& v) { return v > 0; }, "a positive integer");
  }

  void vector3(const std::string& name, Eigen::Vector3d& value) {
    if (!nh_.hasParam(name)) return;
    std::vector<double> v;
    if (!nh_.getParam(name, v) || v.size() != 3) fail(name, "must be a list of 3 numbers");
    for (double x : v) {
      if (!std::isfinite(x) || x <= 0.0) fail(name, "entries must be positive");
    }
    value = Eigen::Vector3d(v[0], v[1], v[2]);
  }

  [[noreturn]] void fail(const std::string& name, const std::string& what) const {
    throw std::invalid_argument("parameter " + nh_.resolveName(name) + " " + what);
  }

 private:
  const ros::NodeHandle& nh_;
};

}  // namespace

NodeParams loadParams(const ros::NodeHandle& private_nh) {
  NodeParams p;
  ParamReader r(private_nh);
  auto frame = [](const std::string& f) { return !f.empty() && f.front() != '/'; };
  r.read<std::string>("map_frame", p.map_frame, frame, "a frame id without a leading '/'");
  r.read<std::string>("odom_frame", p.odom_frame, frame, "a frame id without a leading '/'");
  r.read<std::string>(
      "input_mode", p.input_mode,
      [](const std::string& m) {
        return m == "auto" || m == "odom" || m == "edges" || m == "scan";
      },
      "auto, odom, edges or scan");
  r.read<std::string>("base_frame", p.base_frame, frame, "a frame id without a leading '/'");

  r.positive("min_travel_m", p.keyframes.min_travel_m);
  r.positive("min_rotation_rad", p.keyframes.min_rotation_rad);
  r.vector3("odometry_stddev", p.odometry_stddev);

  // RRR: the preset first, then every parameter of rrr_params.h under its own name, checked by
  // the same validate() as the command-line tools.
  rrr::RrrParams& rrr = p.rrr.rrr;
  std::string preset = "default";
  r.read<std::string>(
      "preset", preset,
      [](const std::string& name) {
        const auto& names = rrr::presetNames();
        return std::find(names.begin(), names.end(), name) != names.end();
      },
      "default or paper");
  rrr::applyPreset(preset, rrr);
  rrr::forEachParam(rrr,
                    [&](const rrr::ParamInfo& info, auto& value) { r.read(info.name, value); });
  try {
    rrr::validate(rrr);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("parameter " + private_nh.resolveName("") + ": " + e.what());
  }
  if (rrr.cluster_gap <= 0) {
    r.fail("cluster_gap",
           "must be a positive number of nodes: the node cannot derive it from candidates "
           "that have not arrived (only rrr_offline can)");
  }
  r.positive("max_waiting_candidates", p.rrr.max_waiting_candidates);

  // Front end (slam mode).
  frontend::LaserSlamParams& slam = p.slam;
  r.positive("scans_per_submap", slam.local.submap.scans_per_submap);
  r.positive("submap_resolution", slam.local.submap.resolution_m);
  r.positive("scan_max_range", slam.local.scan.max_range_m);
  slam.local.submap.max_insertion_range_m = static_cast<float>(slam.local.scan.max_range_m);
  std::string refinement = "least_squares";
  r.read<std::string>(
      "scan_refinement", refinement,
      [](const std::string& m) { return m == "least_squares" || m == "icp"; },
      "least_squares or icp");
  slam.local.refinement = refinement == "icp"
                              ? frontend::LocalSlamParams::Refinement::kIcp
                              : frontend::LocalSlamParams::Refinement::kLeastSquares;
  r.positive("scan_min_travel_m", slam.local.motion_filter.min_travel_m);
  r.positive("scan_min_rotation_rad", slam.local.motion_filter.min_rotation_rad);
  r.read<double>(
      "min_score", slam.loops.min_score, [](const double& v) { return v >= 0.0 && v <= 1.0; },
      "in [0, 1]");
  r.positive("max_constraint_distance", slam.loops.max_constraint_distance_m);
  r.positive("linear_search_window", slam.loops.window.linear_m);
  r.positive("angular_search_window", slam.loops.window.angular_rad);
  r.read<int>(
      "branch_and_bound_depth", slam.local.submap.branch_and_bound_depth,
      [](const int& d) { return d >= 1 && d <= 12; }, "in [1, 12]");
  r.read<int>(
      "search_grid_factor", slam.local.submap.search_grid_factor,
      [](const int& f) { return f >= 1 && f <= 16; }, "in [1, 16]");
  r.positive("min_node_separation", slam.loops.min_node_separation);
  r.positive("loop_search_max_range", slam.loops.max_point_range_m);
  r.positive("search_every_n_nodes", slam.loops.search_every_n_nodes);
  r.read<int>(
      "pause_after_match_nodes", slam.loops.pause_after_match_nodes,
      [](const int& n) { return n >= 0; }, "non-negative");
  r.positive("loop_search_threads", slam.loops.threads);
  r.read<int>(
      "loop_search_min_points", slam.loops.search_min_points, [](const int& n) { return n >= 0; },
      "non-negative");
  r.positive("loop_search_max_voxel", slam.loops.search_voxel_max_m);
  r.vector3("scan_odometry_stddev", slam.odometry_stddev);
  r.positive("map_resolution", p.map_resolution);
  r.positive("map_publish_period", p.map_publish_period);
  r.positive("tf_timeout", p.tf_timeout);

  r.read<bool>(
      "publish_tf", p.publish_tf, [](const bool&) { return true; }, "a boolean");
  r.positive("tf_publish_period", p.tf_publish_period);
  r.read<double>(
      "transform_tolerance", p.transform_tolerance, [](const double& t) { return t >= 0.0; },
      "non-negative");
  r.positive("publish_period", p.publish_period);
  r.positive("status_period", p.status_period);
  r.positive("input_queue_size", p.input_queue_size);
  r.positive("max_backlog", p.max_backlog);
  return p;
}

}  // namespace rrr_graphslam::ros_adapter
