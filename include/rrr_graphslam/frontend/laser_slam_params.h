#pragma once
// The laser SLAM front end's parameters: one definition of each (name, default, range, doc line)
// in forEachSlamParam(), which rrr_slam_offline (--name-with-dashes), the ROS nodelet's slam mode
// (~name) and config/rrr_graphslam.yaml all follow, and one validate() (core/param_info.h).
// RRR's own parameters are rrr_params.h's table.

#include <cmath>

#include <Eigen/Core>

#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/frontend/local_slam.h"
#include "rrr_graphslam/frontend/loop_search.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::frontend {

struct LaserSlamParams {
  LocalSlamParams local;
  LoopSearchParams loops;
  rrr::OnlineRrrParams rrr;
  /// Standard deviations (m, m, rad) of the local-SLAM step between consecutive nodes. The
  /// heading's is what local SLAM drifts by, measured against the corrected logs (bench_slam's
  /// turn-drift column: 0.0013-0.0015 rad per node step on ACES, Intel and FR079, 0.0021 on MIT
  /// CSAIL); stated looser (0.005 before), a long chain of steps bends by degrees at no cost and a
  /// false loop a few metres along a corridor fits
  /// (doc/benchmarks.md#local-slams-steps-as-they-drift).
  Eigen::Vector3d odometry_stddev{0.01, 0.01, 0.0015};
};

inline core::Choices<LocalSlamParams::Refinement> choices(LocalSlamParams::Refinement /*tag*/) {
  return {{LocalSlamParams::Refinement::kLeastSquares, "least_squares"},
          {LocalSlamParams::Refinement::kIcp, "icp"}};
}

/// Calls f(info, field) for every front-end parameter of `p` (LaserSlamParams or const
/// LaserSlamParams) in a fixed order; fields are double, int, bool, LocalSlamParams::Refinement
/// or Eigen::Vector3d. Submaps insert rays up to scan_max_range: after visiting a non-const `p`,
/// its submap insertion range follows the scan's.
template <class Params, class F>
void forEachSlamParam(Params& p, F&& f) {
  auto& local = p.local;
  auto& loops = p.loops;
  // Submaps and scans.
  f(core::ParamInfo{"scans_per_submap", 2, 1e6,
                    "scans inserted per submap; a new one starts at half"},
    local.submap.scans_per_submap);
  f(core::ParamInfo{"submap_resolution", 0.005, 1.0, "m per submap cell"},
    local.submap.resolution_m);
  f(core::ParamInfo{"scan_max_range", 0.1, 1e3,
                    "m; farther readings are neither matched nor inserted"},
    local.scan.max_range_m);
  f(core::ParamInfo{"scan_voxel_size", 0.001, 1.0, "m; one matching point per voxel"},
    local.scan.voxel_size_m);
  // Local SLAM.
  f(core::ParamInfo{"scan_refinement", 0, 0,
                    "after the correlative search: least_squares or icp (MRPT CICP)"},
    local.refinement);
  f(core::ParamInfo{"correlative_search_window", 0.0, 10.0,
                    "m; local SLAM's correlative search +- this (0: least squares only)"},
    local.correlative.linear_window_m);
  f(core::ParamInfo{"scan_velocity_prediction", 0, 1,
                    "where the odometry's prediction is half a window from the last step "
                    "repeated, the window is searched around that too (10% better score wins)"},
    local.velocity_prediction);
  f(core::ParamInfo{"correlative_translation_cost", 0.0, 1e6,
                    "the correlative score is discounted by exp(-(this |dt|^2 + ...))"},
    local.correlative.translation_delta_cost_weight);
  f(core::ParamInfo{"correlative_rotation_cost", 0.0, 1e6, "... and exp(-this dtheta^2)"},
    local.correlative.rotation_delta_cost_weight);
  f(core::ParamInfo{"scan_unknown_probability", 0.0, 1.0,
                    "what never-observed cells of the submaps local SLAM matches score (0.5, "
                    "the occupancy prior, frees a start in a corridor)"},
    local.submap.active_unknown_value);
  f(core::ParamInfo{"young_submap_scans", 0, 1e6,
                    "while a session's first submap holds fewer scans (and less than half of "
                    "scans_per_submap), its never-observed cells score "
                    "young_submap_unknown_probability (0: off)"},
    local.submap.young_submap_scans);
  f(core::ParamInfo{"young_submap_unknown_probability", 0.0, 1.0,
                    "... this (0.5, the occupancy prior: a start in a corridor is not held back)"},
    local.submap.young_unknown_value);
  f(core::ParamInfo{"young_submap_start_speed", 0.0, 1e6,
                    "the first submap is young only when its session starts while the robot "
                    "drives faster than this (m/s, odometry over its first interval between scans "
                    "of up to 1 s; 0: always)"},
    local.young_submap_start_speed);
  f(core::ParamInfo{"scan_translation_weight", 0.0, 1e6,
                    "least squares: pull of the translation toward the prediction"},
    local.least_squares.translation_weight);
  f(core::ParamInfo{"scan_rotation_weight", 0.0, 1e6,
                    "least squares: pull of the rotation toward the correlative match"},
    local.least_squares.rotation_weight);
  f(core::ParamInfo{"scan_min_travel_m", 1e-6, 1e3,
                    "motion filter: a scan becomes a node after this travel (m)"},
    local.motion_filter.min_travel_m);
  f(core::ParamInfo{"scan_min_rotation_rad", 1e-6, M_PI, "... or this rotation (rad)"},
    local.motion_filter.min_rotation_rad);
  f(core::ParamInfo{"scan_max_odometry_jump", 0.01, 1e3,
                    "m; a scan whose odometry moved more is refused (odometry re-anchored)"},
    local.max_odometry_jump_m);
  f(core::ParamInfo{"scan_odometry_stddev", 1e-6, 10.0,
                    "m, m, rad of one local-SLAM step between nodes"},
    p.odometry_stddev);
  // Loop search.
  f(core::ParamInfo{"min_score", 0.0, 1.0, "branch-and-bound score a loop candidate needs"},
    loops.min_score);
  f(core::ParamInfo{"max_constraint_distance", 0.0, 1e6,
                    "m; submaps farther from the node are not searched"},
    loops.max_constraint_distance_m);
  f(core::ParamInfo{"linear_search_window", 0.0, 1e3, "m; loop search +- this in x and y"},
    loops.window.linear_m);
  f(core::ParamInfo{"angular_search_window", 0.0, M_PI, "rad; loop search +- this in yaw"},
    loops.window.angular_rad);
  f(core::ParamInfo{"branch_and_bound_depth", 1, 12, "levels of max-grids per finished submap"},
    local.submap.branch_and_bound_depth);
  f(core::ParamInfo{"search_grid_factor", 1, 16,
                    "branch and bound searches this x coarser cells (max-pooled)"},
    local.submap.search_grid_factor);
  f(core::ParamInfo{"min_node_separation", 1, 1e9,
                    "submaps holding any of the last N nodes are not searched"},
    loops.min_node_separation);
  f(core::ParamInfo{"search_every_n_nodes", 1, 1e6,
                    "a submap is searched by at most every N-th node"},
    loops.search_every_n_nodes);
  f(core::ParamInfo{"pause_after_match_nodes", 0, 1e9,
                    "a submap rests this many nodes after a match"},
    loops.pause_after_match_nodes);
  f(core::ParamInfo{"relocalization_every_n_nodes", 1, 1e6,
                    "until a session is tied to the loaded map, every N-th node searches it whole"},
    loops.relocalization_every_n_nodes);
  f(core::ParamInfo{"relocalization_matches", 1, 1e6,
                    "after N nodes matched the loaded map, RRR decides them and its search rests"},
    loops.relocalization_matches);
  f(core::ParamInfo{"relocalization_confirm_distance", 0.0, 1e6,
                    "m; RRR ties a session to the map by agreeing loops this far apart along it"},
    loops.relocalization_confirm_distance_m);
  f(core::ParamInfo{"relocalization_max_conflict", 0.0, 1.0,
                    "a match to the map is dropped when more of the session's scans it places "
                    "end in the map's free space (1: off)"},
    loops.relocalization_max_conflict);
  f(core::ParamInfo{"relocalization_check_travel", 0.0, 1e6,
                    "m of the session's path whose scans that check places"},
    loops.relocalization_check_travel_m);
  f(core::ParamInfo{"rival_min_loops", 0, 1e6,
                    "once a session is tied, a second reading of where it lies that N of its "
                    "unaccepted loops to the map agree on is searched too (0: off)"},
    loops.rival_min_loops);
  f(core::ParamInfo{"loop_ambiguity_ratio", 0.0, 1.0,
                    "a match is not proposed when a distinct pose of its search scores more than "
                    "this times its score (1: off)"},
    loops.ambiguity_ratio);
  f(core::ParamInfo{"loop_ambiguity_distance", 0.0, 1e3,
                    "m; ... distinct: farther than this from the match, or turned by more than"},
    loops.ambiguity_exclusion.linear_m);
  f(core::ParamInfo{"loop_ambiguity_angle", 0.01, M_PI, "rad; ... this"},
    loops.ambiguity_exclusion.angular_rad);
  f(core::ParamInfo{"loop_search_threads", 1, 256, "threads matching a node against its submaps"},
    loops.threads);
  f(core::ParamInfo{"loop_search_max_range", 0.1, 1e3,
                    "m; farther points are left out of the loop search"},
    loops.max_point_range_m);
  f(core::ParamInfo{"loop_search_min_points", 0, 1e6,
                    "branch and bound scores the scan thinned to about this many points (0: all)"},
    loops.search_min_points);
  f(core::ParamInfo{"loop_search_max_voxel", 0.001, 100.0,
                    "m; ... by a voxel filter no coarser than this"},
    loops.search_voxel_max_m);
  if constexpr (!std::is_const_v<Params>) {
    local.submap.max_insertion_range_m = static_cast<float>(local.scan.max_range_m);
  }
}

/// Throws std::invalid_argument with core::outOfRangeMessage for the first front-end parameter out
/// of its range (RRR's are rrr::validate's).
void validate(const LaserSlamParams& params);

}  // namespace rrr_graphslam::frontend
