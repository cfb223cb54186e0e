#pragma once
// The node's topic names (relative to its namespace), shared by the adapter's source files.

namespace rrr_graphslam::ros_adapter {

inline constexpr const char* kOdomTopic = "odom";
inline constexpr const char* kEdgesTopic = "pose_graph_edges";
inline constexpr const char* kCandidatesTopic = "loop_candidates";
inline constexpr const char* kScanTopic = "scan";
inline constexpr const char* kInitialPoseTopic = "initialpose";

}  // namespace rrr_graphslam::ros_adapter
