#include "rrr_graphslam/frontend/trim_memory.h"

#include <algorithm>
#include <exception>
#include <iterator>
#include <limits>
#include <utility>

#include "rrr_graphslam/frontend/map_render.h"

namespace rrr_graphslam::frontend {
namespace {

// The leaving scans' patches are cut into tiles of this side (m), each anchored to the node
// nearest it.
constexpr double kMemoryTileM = 10.0;

// The node that stays nearest to `at` (map frame); -1 if none stays.
int nearestStaying(const Eigen::Vector2d& at, const std::vector<core::Pose2>& poses,
                   const std::vector<char>& stays) {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (!stays[k]) continue;
    const double d2 = (poses[k].head<2>() - at).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = static_cast<int>(k);
    }
  }
  return best;
}

Eigen::Vector2d patchCentre(const RememberedCells& patch, const core::Pose2& anchor_map_pose) {
  const core::Pose2 centre = core::compose(
      patchPose(patch, anchor_map_pose), core::Pose2(0.5 * patch.width * patch.resolution_m,
                                                     0.5 * patch.height * patch.resolution_m, 0.0));
  return centre.head<2>();
}

// Step 5's patches: per session, the cells its leaving nodes' scans decide together at `poses`
// (a cell a session's passes saw from several submaps' scans is decided as the untrimmed map
// would), in tiles anchored to the nearest node that stays.
std::vector<RememberedCells> rememberLeaving(const MapSnapshot& map,
                                             const std::vector<core::Pose2>& poses,
                                             const std::vector<char>& stays,
                                             const TrimParams& params,
                                             const SubmapParams& submap_params) {
  std::vector<std::vector<std::size_t>> of_session(map.sessions.size());
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    if (!stays[k]) of_session[static_cast<std::size_t>(map.nodes[k].session)].push_back(k);
  }
  const PatchAnchor nearest = [&](const Eigen::Vector2d& centre) {
    const int node = nearestStaying(centre, poses, stays);
    return std::pair{node, poses[static_cast<std::size_t>(std::max(node, 0))]};
  };
  const int sessions = static_cast<int>(map.sessions.size());
  std::vector<std::vector<RememberedCells>> made(map.sessions.size());
  std::vector<std::exception_ptr> failed(map.sessions.size());
#pragma omp parallel for schedule(dynamic) num_threads(params.threads) if (sessions > 1)
  for (int s = 0; s < sessions; ++s) {
    const std::vector<std::size_t>& nodes = of_session[static_cast<std::size_t>(s)];
    if (nodes.empty()) continue;
    try {
      MapInputs inputs;
      inputs.insertion = submap_params;
      inputs.render = params.memory_evidence;
      for (std::size_t k : nodes) {
        inputs.poses.push_back(poses[k]);
        inputs.scans.push_back(map.nodes[k].scan);
      }
      made[static_cast<std::size_t>(s)] =
          rememberScans(inputs, params.memory_resolution_m,
                        map.sessions[static_cast<std::size_t>(s)].number, kMemoryTileM, nearest);
    } catch (...) {
      failed[static_cast<std::size_t>(s)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  std::vector<RememberedCells> patches;
  for (std::vector<RememberedCells>& of : made) {
    patches.insert(patches.end(), std::make_move_iterator(of.begin()),
                   std::make_move_iterator(of.end()));
  }
  return patches;
}

}  // namespace

TrimmedMemory memoryAfterTrim(const MapSnapshot& map, const std::vector<core::Pose2>& poses,
                              const std::vector<char>& stays, const TrimParams& params,
                              const SubmapParams& submap_params, bool remember) {
  TrimmedMemory out;
  for (const RememberedCells& patch : map.memory) {
    const auto anchor = static_cast<std::size_t>(patch.anchor_node);
    if (stays[anchor]) {
      out.patches.push_back(patch);
      continue;
    }
    const int to = nearestStaying(patchCentre(patch, poses[anchor]), poses, stays);
    if (to >= 0) {  // some node always stays (the newest submaps): never dropped
      out.patches.push_back(
          reanchored(patch, poses[anchor], to, poses[static_cast<std::size_t>(to)]));
    }
  }
  if (remember && std::find(stays.begin(), stays.end(), 1) != stays.end()) {
    std::vector<RememberedCells> made = rememberLeaving(map, poses, stays, params, submap_params);
    out.made_patches = static_cast<int>(made.size());
    out.patches.insert(out.patches.end(), std::make_move_iterator(made.begin()),
                       std::make_move_iterator(made.end()));
  }
  return out;
}

std::size_t settleMemory(TrimmedMemory& memory, const std::vector<int>& new_index,
                         const MapSnapshot& trimmed, const TrimParams& params) {
  for (RememberedCells& patch : memory.patches) {
    patch.anchor_node = new_index[static_cast<std::size_t>(patch.anchor_node)];
  }
  if (memory.made_patches == 0) return 0;
  std::vector<core::Pose2> anchors;
  anchors.reserve(trimmed.nodes.size());
  for (const MapSnapshot::Node& node : trimmed.nodes) anchors.push_back(node.map_pose);
  const std::size_t before = rememberedCells(memory.patches);
  memory.patches = forgetSuperseded(memory.patches, anchors, params.memory_resolution_m);
  return before - rememberedCells(memory.patches);
}

}  // namespace rrr_graphslam::frontend
