#include "rrr_graphslam/ros/params.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <type_traits>
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

  // Reads a table parameter (core/param_info.h) if set: the type must match (a number for an int
  // or double, true/false for a bool, a choice's name for an enum, a list of 3 numbers for a
  // vector); the range is checked by the table's validate().
  template <class T>
  void read(const core::ParamInfo& info, T& value) {
    const std::string name = info.name;
    if (!nh_.hasParam(name)) return;
    if constexpr (std::is_enum_v<T>) {
      std::string text;
      if (!nh_.getParam(name, text)) fail(name, "has the wrong type: a string is expected");
      if (!core::parseChoice(text, value)) {
        throw std::invalid_argument("parameter " + nh_.resolveName("") + ": " +
                                    core::notAChoiceMessage(info, text, core::choiceNames<T>()));
      }
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      value = numbers3(name);
    } else if (!nh_.getParam(name, value)) {
      fail(name, "has the wrong type");
    }
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
    value = numbers3(name);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(value[k]) || value[k] <= 0.0) fail(name, "entries must be positive");
    }
  }

  // A list of 3 numbers (integers allowed, as YAML writes 1 for 1.0).
  Eigen::Vector3d numbers3(const std::string& name) const {
    XmlRpc::XmlRpcValue list;
    if (!nh_.getParam(name, list) || list.getType() != XmlRpc::XmlRpcValue::TypeArray ||
        list.size() != 3) {
      fail(name, "must be a list of 3 numbers");
    }
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) {
      XmlRpc::XmlRpcValue& x = list[k];
      if (x.getType() == XmlRpc::XmlRpcValue::TypeInt) {
        v[k] = static_cast<int>(x);
      } else if (x.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
        v[k] = static_cast<double>(x);
      } else {
        fail(name, "must be a list of 3 numbers");
      }
    }
    return v;
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
  rrr::forEachParam(rrr, [&](const core::ParamInfo& info, auto& value) { r.read(info, value); });
  r.read(core::ParamInfo{"max_waiting_candidates", 0, 1e9, ""}, p.rrr.max_waiting_candidates);
  // Another verifier to compare with RRR (rrr_offline --verifier): decided again whenever a
  // time cluster closes.
  rrr::VerifierChoice& verifier = p.rrr.verifier;
  r.read(core::ParamInfo{"verifier", 0, 0, ""}, verifier.verifier);
  r.read(core::ParamInfo{"gnc_loss", 0, 0, ""}, verifier.gnc_loss);
  r.read<double>(
      "scgp_ratio", verifier.scgp_ratio, [](const double& v) { return v >= 1.0; }, "at least 1");

  // Front end (slam mode): every parameter of laser_slam_params.h under its own name.
  frontend::forEachSlamParam(
      p.slam, [&](const core::ParamInfo& info, auto& value) { r.read(info, value); });
  frontend::forEachMapRenderParam(
      p.map_render, [&](const core::ParamInfo& info, auto& value) { r.read(info, value); });
  try {
    rrr::validate(p.rrr);
    frontend::validate(p.slam);
    frontend::validate(p.map_render);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("parameter " + private_nh.resolveName("") + ": " + e.what());
  }
  r.positive("map_resolution", p.map_resolution);
  r.read(core::ParamInfo{"map_layering", 0, 0, ""}, p.map_layering);
  r.read<std::string>(
      "map_file", p.map_file, [](const std::string&) { return true; }, "a path");
  r.read<std::string>(
      "mode", p.mode, [](const std::string& m) { return m == "mapping" || m == "localization"; },
      "mapping or localization");
  r.read<bool>(
      "lifelong", p.lifelong, [](const bool&) { return true; }, "a boolean");
  r.read<double>(
      "trim_overlap_ratio", p.trim.trim_overlap_ratio,
      [](const double& v) { return v > 0.0 && v <= 1.0; }, "in (0, 1]");
  std::string trim_rule = frontend::toString(p.trim.trim_rule);
  r.read<std::string>(
      "trim_rule", trim_rule,
      [](const std::string& s) { return s == "overlap-ratio" || s == "fresh-area"; },
      "overlap-ratio or fresh-area");
  p.trim.trim_rule = frontend::parseTrimRule(trim_rule);
  r.read<double>(
      "trim_min_fresh_area_m2", p.trim.trim_min_fresh_area_m2,
      [](const double& v) { return v >= 0.0 && std::isfinite(v); }, "at least 0 (m^2)");
  r.read<int>(
      "keep_recent_submaps", p.trim.keep_recent_submaps, [](const int& v) { return v >= 1; },
      "at least 1");
  r.read<bool>(
      "keep_current_session", p.trim.keep_current_session, [](const bool&) { return true; },
      "a boolean");
  r.read<bool>(
      "remember_trimmed_cells", p.trim.remember_trimmed_cells, [](const bool&) { return true; },
      "a boolean");
  p.trim.memory_evidence = p.map_render;
  std::string sparsification = frontend::toString(p.trim.sparsification);
  r.read<std::string>(
      "sparsification", sparsification,
      [](const std::string& s) { return s == "clt" || s == "dense" || s == "delete"; },
      "clt, dense or delete");
  p.trim.sparsification = frontend::parseSparsification(sparsification);
  r.read<bool>(
      "clt_conservative", p.trim.chow_liu.conservative, [](const bool&) { return true; },
      "a boolean");
  r.read<bool>(
      "clt_per_edge_scaling", p.trim.chow_liu.per_edge_scaling, [](const bool&) { return true; },
      "a boolean");
  r.read<int>(
      "trim_every_n_nodes", p.trim_every_n_nodes, [](const int& v) { return v >= 0; },
      "at least 0 (0: trim only when ~save_map writes the map)");
  if (p.trim_every_n_nodes > 0 && p.trim.sparsification == frontend::Sparsification::kDelete) {
    throw std::invalid_argument("parameter " + private_nh.resolveName("trim_every_n_nodes") +
                                " is " + std::to_string(p.trim_every_n_nodes) +
                                ": online trimming needs sparsification clt or dense (deletion "
                                "would drop the running session's loops to the map)");
  }
  if (p.trim_every_n_nodes > 0 && !p.lifelong) {
    throw std::invalid_argument("parameter " + private_nh.resolveName("trim_every_n_nodes") +
                                " is " + std::to_string(p.trim_every_n_nodes) +
                                ": online trimming needs lifelong true");
  }
  p.trim.threads = p.slam.loops.threads;
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
