#include "rrr_graphslam/frontend/loop_search.h"

#include "rrr_graphslam/frontend/voxel_filter.h"

namespace rrr_graphslam::frontend {
namespace {

// The refined match as a constraint anchor -> node: the information of the node's pose in the
// submap frame, rotated into the anchor's frame.
LoopMatch toLoop(const Submap& submap, int node, const PointCloud& points, const ScanMatch& match,
                 const LoopSearchParams& params) {
  const RefinedMatch refined =
      refineLeastSquares(submap.matchGrid(), match.pose, match.pose, points, params.refinement);
  LoopMatch loop;
  loop.submap = submap.index();
  loop.from = submap.anchorNode();
  loop.to = node;
  loop.measurement = core::between(submap.anchorPose(), refined.pose);
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
  J.topLeftCorner<2, 2>() = core::rotation(submap.anchorPose().z()).transpose();
  loop.information = J * refined.information * J.transpose();
  loop.score = match.score;
  return loop;
}

PointCloud searchPoints(const PointCloud& points, const LoopSearchParams& params) {
  return params.search_min_points > 0
             ? adaptiveVoxelFilter(points, params.search_voxel_max_m, params.search_min_points)
             : points;
}

}  // namespace

std::optional<LoopMatch> matchNodeToSubmap(const Submap& submap, int node, const PointCloud& points,
                                           const core::Pose2& initial,
                                           const LoopSearchParams& params) {
  if (submap.matcher() == nullptr) return std::nullopt;
  const auto match = submap.matcher()->match(initial, searchPoints(points, params), params.window,
                                             params.min_score);
  if (!match) return std::nullopt;
  return toLoop(submap, node, points, *match, params);
}

std::optional<LoopMatch> matchNodeToWholeSubmap(const Submap& submap, int node,
                                                const PointCloud& points,
                                                const LoopSearchParams& params) {
  if (submap.matcher() == nullptr) return std::nullopt;
  const auto match =
      submap.matcher()->matchFullSubmap(searchPoints(points, params), params.min_score);
  if (!match) return std::nullopt;
  return toLoop(submap, node, points, *match, params);
}

}  // namespace rrr_graphslam::frontend
