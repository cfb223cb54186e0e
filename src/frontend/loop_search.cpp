#include "rrr_graphslam/frontend/loop_search.h"

#include <limits>
#include <utility>

#include "rrr_graphslam/frontend/voxel_filter.h"

namespace rrr_graphslam::frontend {
namespace {

// Mean probability of the submap's full-resolution grid under the points placed at `pose`.
double fineScore(const MatchGrid& grid, const core::Pose2& pose, const PointCloud& points) {
  const Eigen::Matrix2d R = core::rotation(pose.z());
  double sum = 0.0;
  for (const auto& p : points) {
    const Eigen::Array2i c = grid.cellOf(pose.head<2>() + R * p);
    sum += grid.at(c.x(), c.y());
  }
  return points.empty() ? 0.0 : sum / static_cast<double>(points.size());
}

// The submap's node nearest to `pose` (submap frame), the anchor if it has none recorded.
// Local SLAM drifts within a submap (FR079: up to 6 degrees over one submap's span), and the grid
// where a node matched agrees with the nodes inserted there, not with the anchor's pose metres
// away: a constraint from the anchor would carry that drift into the map (issue 24).
Submap::Member nearestMember(const Submap& submap, const core::Pose2& pose) {
  Submap::Member best{submap.anchorNode(), submap.anchorPose()};
  double best_sq = std::numeric_limits<double>::infinity();
  for (const Submap::Member& m : submap.members()) {
    const double sq = (m.local_pose.head<2>() - pose.head<2>()).squaredNorm();
    if (sq < best_sq) {
      best_sq = sq;
      best = m;
    }
  }
  return best;
}

// The refined match as a constraint from the submap's node nearest to it to the node: the
// information of the node's pose in the submap frame, rotated into that node's frame. When branch
// and bound searched a coarser grid than the submap's, its score flatters the match: the refined
// pose must score above min_score on the full-resolution grid too (nullopt otherwise).
std::optional<LoopMatch> toLoop(const Submap& submap, int node, const LoopSearchScan& scan,
                                const ScanMatch& match, const LoopSearchParams& params) {
  const RefinedMatch refined = refineLeastSquares(submap.matchGrid(), match.pose, match.pose,
                                                  scan.points, params.refinement);
  const bool coarse = submap.matcher()->resolution() > submap.matchGrid().resolution() * 1.5;
  if (coarse &&
      fineScore(submap.matchGrid(), refined.pose, scan.search_points) <= params.min_score) {
    return std::nullopt;
  }
  const Submap::Member origin = nearestMember(submap, refined.pose);
  LoopMatch loop;
  loop.submap = submap.index();
  loop.from = origin.node;
  loop.to = node;
  loop.measurement = core::between(origin.local_pose, refined.pose);
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
  J.topLeftCorner<2, 2>() = core::rotation(origin.local_pose.z()).transpose();
  loop.information = J * refined.information * J.transpose();
  loop.score = match.score;
  return loop;
}

// The best match of `branch_and_bound(min_score, exclusion)` as a loop, unless a distinct pose
// scores nearly as well (ambiguity_ratio).
template <typename BranchAndBound>
SubmapSearch searchUnlessAmbiguous(const Submap& submap, int node, const LoopSearchScan& scan,
                                   const LoopSearchParams& params,
                                   BranchAndBound branch_and_bound) {
  const std::optional<ScanMatch> match = branch_and_bound(params.min_score, std::nullopt);
  if (!match) return {};
  SubmapSearch out;
  out.loop = toLoop(submap, node, scan, *match, params);
  // Only a match that would be proposed pays for the second search (and counts as ambiguous).
  if (out.loop && params.ambiguity_ratio < 1.0) {
    const Exclusion own_place{match->pose, params.ambiguity_exclusion.linear_m,
                              params.ambiguity_exclusion.angular_rad};
    out.alias = branch_and_bound(std::max(params.min_score, params.ambiguity_ratio * match->score),
                                 std::optional<Exclusion>(own_place));
    if (out.alias) out.loop.reset();
  }
  return out;
}

}  // namespace

LoopSearchScan loopSearchScan(PointCloud points, const LoopSearchParams& params) {
  PointCloud search_points =
      params.search_min_points > 0
          ? adaptiveVoxelFilter(points, params.search_voxel_max_m, params.search_min_points)
          : points;
  return {std::move(points), std::move(search_points)};
}

SubmapSearch matchNodeToSubmap(const Submap& submap, int node, const LoopSearchScan& scan,
                               const core::Pose2& initial, const LoopSearchParams& params) {
  if (submap.matcher() == nullptr) return {};
  return searchUnlessAmbiguous(submap, node, scan, params,
                               [&](double min_score, const auto& exclude) {
                                 return submap.matcher()->match(initial, scan.search_points,
                                                                params.window, min_score, exclude);
                               });
}

SubmapSearch matchNodeToWholeSubmap(const Submap& submap, int node, const LoopSearchScan& scan,
                                    const LoopSearchParams& params) {
  if (submap.matcher() == nullptr) return {};
  return searchUnlessAmbiguous(
      submap, node, scan, params, [&](double min_score, const auto& exclude) {
        return submap.matcher()->matchFullSubmap(scan.search_points, min_score, exclude);
      });
}

}  // namespace rrr_graphslam::frontend
