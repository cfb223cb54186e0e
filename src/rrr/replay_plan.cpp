#include "rrr_graphslam/rrr/replay_plan.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace rrr_graphslam::rrr {

std::vector<NodeArrivals> arrivalsByNode(int num_nodes, const std::vector<ReplayEdge>& edges,
                                         const std::vector<std::vector<int>>& dense_factors) {
  std::vector<NodeArrivals> at(static_cast<std::size_t>(std::max(num_nodes, 0)));
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const ReplayEdge& e = edges[k];
    if (std::min(e.from, e.to) < 0 || std::max(e.from, e.to) >= num_nodes) {
      throw std::invalid_argument("arrivalsByNode: edge " + std::to_string(k) + " joins " +
                                  std::to_string(e.from) + " and " + std::to_string(e.to) +
                                  ", outside the " + std::to_string(num_nodes) + " nodes");
    }
    NodeArrivals& node = at[static_cast<std::size_t>(std::max(e.from, e.to))];
    (e.kind == core::EdgeKind::kOdometry   ? node.odometry
     : e.kind == core::EdgeKind::kMarginal ? node.marginal
                                           : node.candidates)
        .push_back(static_cast<int>(k));
  }
  for (std::size_t f = 0; f < dense_factors.size(); ++f) {
    const std::vector<int>& nodes = dense_factors[f];
    if (nodes.empty() || *std::min_element(nodes.begin(), nodes.end()) < 0 ||
        *std::max_element(nodes.begin(), nodes.end()) >= num_nodes) {
      throw std::invalid_argument("arrivalsByNode: dense factor " + std::to_string(f) +
                                  " holds a node outside the " + std::to_string(num_nodes) +
                                  " nodes");
    }
    at[static_cast<std::size_t>(*std::max_element(nodes.begin(), nodes.end()))].dense.push_back(
        static_cast<int>(f));
  }
  return at;
}

namespace {

std::unordered_map<core::PoseGraph::NodeId, int> denseIndices(const core::PoseGraph& graph) {
  std::unordered_map<core::PoseGraph::NodeId, int> index_of;
  const auto ids = graph.nodeIds();
  for (std::size_t i = 0; i < ids.size(); ++i) index_of.emplace(ids[i], static_cast<int>(i));
  return index_of;
}

}  // namespace

std::vector<std::vector<int>> replayDenseFactors(const core::PoseGraph& graph) {
  const auto index_of = denseIndices(graph);
  std::vector<std::vector<int>> factors;
  for (const core::DenseFactor& f : graph.denseFactors()) {
    factors.emplace_back();
    for (core::PoseGraph::NodeId id : f.nodes) factors.back().push_back(index_of.at(id));
  }
  return factors;
}

std::vector<ReplayEdge> replayEdges(const core::PoseGraph& graph) {
  const auto index_of = denseIndices(graph);
  std::vector<ReplayEdge> edges;
  edges.reserve(graph.numEdges());
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    const auto& edge = graph.edge(e);
    edges.push_back({index_of.at(edge.from), index_of.at(edge.to), edge.kind});
  }
  return edges;
}

}  // namespace rrr_graphslam::rrr
