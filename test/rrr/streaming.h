#pragma once
// Test helpers for OnlineRrr: a pose graph streamed into it as a robot sends it, and candidates
// told apart by their ends and measurement (arrival order differs from a file's edge order).

#include <gtest/gtest.h>

#include <cstddef>
#include <map>
#include <set>
#include <tuple>
#include <vector>

#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::rrr::testing {

using NodeId = core::PoseGraph::NodeId;
using Key = std::tuple<NodeId, NodeId, double, double, double>;

inline Key keyOf(NodeId from, NodeId to, const core::Pose2& z) {
  return {from, to, z[0], z[1], z[2]};
}

/// The graph without exact duplicate loop edges (Intel holds a few), which OnlineRrr refuses as
/// re-sent messages.
inline core::PoseGraph withoutDuplicateCandidates(const core::PoseGraph& g) {
  core::PoseGraph out;
  for (NodeId id : g.nodeIds()) out.addNode(id, g.pose(id));
  std::set<Key> seen;
  for (std::size_t e = 0; e < g.numEdges(); ++e) {
    const auto& edge = g.edge(e);
    if (edge.kind == core::EdgeKind::kLoopCandidate &&
        !seen.insert(keyOf(edge.from, edge.to, g.measurement(e))).second) {
      continue;
    }
    out.addEdge(edge.from, edge.to, g.measurement(e), g.information(e), edge.kind);
  }
  return out;
}

/// Streams `g` as a robot would: odometry node by node, each candidate once both ends exist, or
/// (early) as soon as its older end exists. Ends with finish() unless `finish` is false.
inline void stream(const core::PoseGraph& g, OnlineRrr& online, bool early, bool finish = true) {
  std::map<NodeId, std::vector<std::size_t>> odometry_into, candidates_at;
  for (std::size_t e = 0; e < g.numEdges(); ++e) {
    const auto& edge = g.edge(e);
    ASSERT_LT(edge.from, edge.to) << "the test streams forward edges only";
    if (edge.kind == core::EdgeKind::kOdometry) {
      odometry_into[edge.to].push_back(e);
    } else {
      candidates_at[early ? edge.from : edge.to].push_back(e);
    }
  }
  const auto ids = g.nodeIds();
  online.startSession(ids[0], g.pose(ids[0]));
  for (NodeId id : ids) {
    if (id != ids[0]) {
      ASSERT_EQ(odometry_into[id].size(), 1u) << "node " << id;
      const std::size_t e = odometry_into[id][0];
      online.addOdometry(g.edge(e).from, id, g.measurement(e), g.information(e));
    }
    for (std::size_t e : candidates_at[id]) {
      online.addCandidate(g.edge(e).from, g.edge(e).to, g.measurement(e), g.information(e));
    }
  }
  if (finish) online.finish();
}

}  // namespace rrr_graphslam::rrr::testing
