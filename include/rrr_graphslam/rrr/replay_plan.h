#pragma once
// The order in which a robot would have built a stored graph: nodes in id order, each with the
// odometry edges into it, then the marginal constraints and the loop candidates whose newest end
// it is (input order within a node); dense factors arrive with their newest node too, beside the
// marginal constraints. rrr_offline --mode incremental, OnlineRrr::fromPoseGraph
// (~load) and the tests replay graphs in this one order; the Python module's plan_replay does the
// same for ROS replays.

#include <vector>

#include "rrr_graphslam/core/pose_graph.h"

namespace rrr_graphslam::rrr {

/// An edge by its dense node indices (k-th smallest id = k) and kind.
struct ReplayEdge {
  int from;
  int to;
  core::EdgeKind kind;
};

/// What arrives with one node: indices into the edge list.
struct NodeArrivals {
  std::vector<int> odometry;    ///< odometry edges whose newest end the node is
  std::vector<int> marginal;    ///< then the marginal constraints whose newest end it is
  std::vector<int> dense;       ///< and the dense factors whose newest node it is
  std::vector<int> candidates;  ///< then the loop candidates whose newest end it is
};

/// One entry per node; edges and dense factors (each by its dense node indices) must join nodes in
/// [0, num_nodes) (std::invalid_argument otherwise).
std::vector<NodeArrivals> arrivalsByNode(int num_nodes, const std::vector<ReplayEdge>& edges,
                                         const std::vector<std::vector<int>>& dense_factors = {});

/// A PoseGraph's dense factors, each by the dense node indices of its nodes (factor order).
std::vector<std::vector<int>> replayDenseFactors(const core::PoseGraph& graph);

/// A PoseGraph's edges in edge order, by dense node index and kind.
std::vector<ReplayEdge> replayEdges(const core::PoseGraph& graph);

}  // namespace rrr_graphslam::rrr
