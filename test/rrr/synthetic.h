#pragma once
// Test inputs for RRR: a bundled graph with false loop closures added (fixed seed), labels kept.

#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::rrr::testing {

struct LabelledGraph {
  core::PoseGraph graph;
  std::vector<bool> candidate_is_true;  ///< per loop candidate, in edge order
};

/// Adds `count` false loops (in groups of `group` consistent links) to `path`'s graph, like
/// scripts/add_outliers: ends anywhere, or with `local_window` > 0 the second end 2 to
/// local_window nodes after the first; measurement x, y ~ N(0, 0.3 m), theta ~ N(0, 10 deg).
inline LabelledGraph withOutliers(const std::string& path, int count, int group, unsigned seed,
                                  int local_window = 0) {
  LabelledGraph out{core::readPoseGraph(path), {}};
  core::PoseGraph& g = out.graph;
  Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  std::set<std::pair<core::PoseGraph::NodeId, core::PoseGraph::NodeId>> used;
  for (std::size_t k = 0; k < g.numEdges(); ++k) {
    used.emplace(g.edge(k).from, g.edge(k).to);
    if (g.edge(k).kind == core::EdgeKind::kLoopCandidate) {
      if (out.candidate_is_true.empty()) info = g.information(k);
      out.candidate_is_true.push_back(true);
    }
  }
  const auto ids = g.nodeIds();
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0,
                                                  ids.size() - 1 - static_cast<std::size_t>(group));
  std::normal_distribution<double> metres(0.0, 0.3), radians(0.0, 10.0 * M_PI / 180.0);
  int added = 0;
  while (added < count) {
    std::size_t a = pick(rng), b = pick(rng);
    if (local_window > 0) b = a + 2 + b % static_cast<std::size_t>(local_window - 1);
    if (b + static_cast<std::size_t>(group) >= ids.size()) continue;
    if (a > b) std::swap(a, b);
    if (b - a < 2 || used.count({ids[a], ids[b]})) continue;
    const core::Pose2 z(metres(rng), metres(rng), radians(rng));
    for (int k = 0; k < group && added < count; ++k, ++added) {
      used.emplace(ids[a + static_cast<std::size_t>(k)], ids[b + static_cast<std::size_t>(k)]);
      g.addEdge(ids[a + static_cast<std::size_t>(k)], ids[b + static_cast<std::size_t>(k)], z, info,
                core::EdgeKind::kLoopCandidate);
      out.candidate_is_true.push_back(false);
    }
  }
  return out;
}

/// Adds false loops in groups of `group` links until they number `count`: each group joins a run
/// of consecutive nodes a.. to a later run b.. (at least `group` + 40 nodes on) as if the second
/// run lay at `offset` from where `map` has it: one wrong rigid offset per group, so a group
/// agrees with itself and with the odometry on both sides (scripts/add_outliers --kind aliased,
/// one offset for every group: a place seen again and again that looks like another).
inline LabelledGraph withAliasedGroups(const core::PoseGraph& original,
                                       const std::vector<core::Pose2>& map,
                                       const core::Pose2& offset, int count, int group,
                                       const Eigen::Matrix3d& information, unsigned seed) {
  LabelledGraph out{original, {}};
  for (std::size_t k = 0; k < original.numEdges(); ++k) {
    if (original.edge(k).kind == core::EdgeKind::kLoopCandidate)
      out.candidate_is_true.push_back(true);
  }
  const auto ids = original.nodeIds();
  const auto run = static_cast<std::size_t>(group);
  if (group < 1 || ids.size() < 2 * run + 41) {
    throw std::invalid_argument("withAliasedGroups: too few nodes for two runs of the group");
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1 - run);
  int added = 0;
  while (added < count) {
    const std::size_t a = pick(rng), b = pick(rng);
    if (a + run + 40 > b) continue;
    for (std::size_t k = 0; k < run && added < count; ++k, ++added) {
      out.graph.addEdge(ids[a + k], ids[b + k],
                        core::between(map[a + k], core::compose(offset, map[b + k])), information,
                        core::EdgeKind::kLoopCandidate);
      out.candidate_is_true.push_back(false);
    }
  }
  return out;
}

}  // namespace rrr_graphslam::rrr::testing
