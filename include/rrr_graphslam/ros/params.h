#pragma once
// Every parameter of the node in one struct with its defaults, and the loader that reads it from
// the private namespace (config/rrr_graphslam.yaml) and refuses bad values naming the parameter.

#include <string>

#include <ros/node_handle.h>
#include <Eigen/Core>

#include "rrr_graphslam/core/keyframe_selector.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::ros_adapter {

struct NodeParams {
  // Frames (REP 105).
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";  ///< slam mode: the robot frame the scans are placed in
  /// "auto": the first input that creates a node (odom or pose_graph_edges) owns the graph until
  /// ~reset; "odom" or "edges" fix it. "scan": slam mode, the front end builds the graph from
  /// `scan` (sensor_msgs/LaserScan) and tf odom_frame -> base_frame and publishes `map`.
  /// Messages of the other inputs are counted as ignored.
  std::string input_mode = "auto";

  // Nodes from odometry.
  core::KeyframeParams keyframes;
  /// Odometry noise when the Odometry message's pose covariance does not give the step's (zero,
  /// or constant instead of growing as dead reckoning does): standard deviations of x and y in
  /// metres per metre driven, of yaw in radians per radian turned and per metre driven
  /// (core::MotionNoise); default 0.05, 0.05, 0.02.
  Eigen::Vector3d odometry_stddev{0.05, 0.05, 0.02};

  // RRR (cluster_gap in nodes, alpha, ...).
  rrr::OnlineRrrParams rrr;

  // Slam mode: the front end (its rrr member is ignored: `rrr` above is used), the map output and
  // how long a scan waits for its tf.
  frontend::LaserSlamParams slam;
  double map_resolution = 0.05;  ///< m per cell of the published map
  /// How the published map layers the sessions' scans (map_render.h): every scan alike, or each
  /// cell as the newest session that observed it saw it (a world that changed between sessions).
  frontend::MapLayering map_layering = frontend::MapLayering::kAllScans;
  frontend::MapRenderParams map_render;  ///< map_hit_probability, map_miss_probability
  std::string map_file;                  ///< slam mode: a saved map (*.rrrmap) to continue at start
  /// slam mode with a map (map_file, ~load_map): "mapping" extends it, "localization" tracks the
  /// robot in it and leaves it as it was loaded.
  std::string mode = "mapping";
  /// slam mode: ~save_map trims the map it writes (doc/lifelong.md): the submaps newer ones cover
  /// leave, their nodes marginalized into marginal edges. trim: trim_overlap_ratio,
  /// keep_recent_submaps, sparsification (clt or delete).
  bool lifelong = false;
  frontend::TrimParams trim;
  /// slam mode, lifelong: the earlier sessions are also trimmed while the current one maps,
  /// every this many of its nodes once it is tied to the map, on a thread of its own
  /// (frontend/online_trimmer.h); 0 (default): only when ~save_map writes the map.
  int trim_every_n_nodes = 0;
  double map_publish_period = 5.0;  ///< s between map renderings while scans arrive
  double tf_timeout = 0.2;          ///< s a scan waits for odom_frame -> base_frame

  // Output.
  bool publish_tf = true;
  double tf_publish_period = 0.05;   ///< s
  double transform_tolerance = 0.1;  ///< s added to the map->odom stamp, as amcl does
  double publish_period = 0.2;       ///< s between path/marker updates while input is queued
  double status_period = 1.0;        ///< s between status messages when nothing happens

  // Input.
  int input_queue_size = 10000;  ///< roscpp subscriber queues
  int max_backlog = 1000000;     ///< messages queued for the worker, at most (then refused, logged)
};

/// Reads the parameters from `private_nh`; throws std::invalid_argument naming the parameter.
NodeParams loadParams(const ros::NodeHandle& private_nh);

}  // namespace rrr_graphslam::ros_adapter
