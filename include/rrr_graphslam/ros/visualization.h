#pragma once
// What rviz shows of the graph: one LINE_LIST marker per namespace ("odometry", "loops_accepted"
// green, "loops_rejected" red, "loops_pending" yellow, "marginal" purple: what lifelong trimming
// left of removed nodes, "dense" orange: its exact marginals, each drawn as a star from its
// root) plus the "nodes" as points, and the optimized path. All in the map
// frame, at the map poses.

#include <string>
#include <vector>

#include <nav_msgs/Path.h>
#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::ros_adapter {

visualization_msgs::MarkerArray buildMarkers(const rrr::OnlineRrr& graph,
                                             const std::vector<core::Pose2>& map_poses,
                                             const std::string& frame, const ros::Time& stamp);

/// One pose per node in node order; each pose's header has the node's stamp and, in seq, its id.
nav_msgs::Path buildPath(const rrr::OnlineRrr& graph, const std::vector<core::Pose2>& map_poses,
                         const std::vector<ros::Time>& node_stamps, const std::string& frame,
                         const ros::Time& stamp);

}  // namespace rrr_graphslam::ros_adapter
