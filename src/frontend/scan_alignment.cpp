#include "rrr_graphslam/frontend/scan_alignment.h"

#include <algorithm>
#include <cmath>

#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/slam/CICP.h>

#include "rrr_graphslam/frontend/match_grid.h"

namespace rrr_graphslam::frontend {
namespace {

// The reference's points as a grid: 1 in a point's cell, neighbour_value around it, 0 elsewhere
// (and outside), with a margin of one cell.
MatchGrid pointGrid(const PointCloud& points, const ScanAlignmentParams& params) {
  Eigen::Vector2d low = points.front(), high = points.front();
  for (const auto& p : points) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  const double r = params.resolution_m;
  const Eigen::Vector2d origin = low - Eigen::Vector2d::Constant(2.0 * r);
  const int width = static_cast<int>(std::ceil((high.x() - origin.x()) / r)) + 3;
  const int height = static_cast<int>(std::ceil((high.y() - origin.y()) / r)) + 3;
  MatchGrid grid(origin, r, width, height, 0.0F);
  const auto neighbour = static_cast<float>(params.neighbour_value);
  for (const auto& p : points) {
    const Eigen::Array2i c = grid.cellOf(p);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const float value = dx == 0 && dy == 0 ? 1.0F : neighbour;
        if (grid.at(c.x() + dx, c.y() + dy) < value) grid.set(c.x() + dx, c.y() + dy, value);
      }
    }
  }
  return grid;
}

mrpt::maps::CSimplePointsMap pointsMap(const PointCloud& points) {
  mrpt::maps::CSimplePointsMap map;
  map.reserve(points.size());
  for (const auto& p : points) {
    map.insertPoint(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0F);
  }
  return map;
}

// overlapFraction against a reference already in a points map (its KD-tree built once).
double overlapIn(const mrpt::maps::CSimplePointsMap& reference, const PointCloud& query,
                 const core::Pose2& query_pose, double distance_m) {
  if (query.empty() || reference.empty()) return 0.0;
  const Eigen::Matrix2d R = core::rotation(query_pose.z());
  const double max_sq = distance_m * distance_m;
  std::size_t within = 0;
  for (const auto& p : query) {
    const Eigen::Vector2d q = query_pose.head<2>() + R * p;
    const float sq = reference.kdTreeClosestPoint2DsqrError(static_cast<float>(q.x()),
                                                            static_cast<float>(q.y()));
    within += static_cast<double>(sq) <= max_sq;
  }
  return static_cast<double>(within) / static_cast<double>(query.size());
}

}  // namespace

core::Pose2 refineScanIcp(const PointCloud& reference, const PointCloud& query,
                          const core::Pose2& initial, const ScanAlignmentParams& params) {
  if (reference.empty() || query.empty()) return initial;
  const mrpt::maps::CSimplePointsMap reference_map = pointsMap(reference);
  const mrpt::maps::CSimplePointsMap query_map = pointsMap(query);
  mrpt::slam::CICP icp;
  icp.options.ICP_algorithm = mrpt::slam::icpClassic;
  icp.options.maxIterations = params.icp_max_iterations;
  icp.options.thresholdDist = params.icp_threshold_dist_m;
  icp.options.smallestThresholdDist = params.icp_smallest_threshold_dist_m;
  icp.options.corresponding_points_decimation = 1;
  icp.options.skip_cov_calculation = true;
  mrpt::slam::CICP::TReturnInfo info;
  const auto pdf = icp.Align(&reference_map, &query_map,
                             mrpt::poses::CPose2D(initial.x(), initial.y(), initial.z()), info);
  if (!pdf) return initial;
  const mrpt::poses::CPose2D mean = pdf->getMeanVal();
  const core::Pose2 refined(mean.x(), mean.y(), core::normalizeAngle(mean.phi()));
  // ICP may slide along a corridor: keep its pose only where it overlaps at least as well.
  return overlapIn(reference_map, query, refined, params.resolution_m) >=
                 overlapIn(reference_map, query, initial, params.resolution_m)
             ? refined
             : initial;
}

std::optional<ScanAlignment> alignScans(const PointCloud& reference, const PointCloud& query,
                                        const core::Pose2& initial,
                                        const ScanAlignmentParams& params) {
  if (reference.empty() || query.empty()) return std::nullopt;
  const FastCorrelativeScanMatcher matcher(pointGrid(reference, params),
                                           params.branch_and_bound_depth);
  const auto match = matcher.match(initial, query, params.window, params.min_score);
  if (!match) return std::nullopt;
  return ScanAlignment{refineScanIcp(reference, query, match->pose, params), match->score};
}

PointCloud surfacePoints(const PointCloud& points, double max_gap_m, double step_m) {
  PointCloud out;
  for (std::size_t k = 0; k < points.size(); ++k) {
    out.push_back(points[k]);
    if (k + 1 == points.size()) break;
    const Eigen::Vector2d d = points[k + 1] - points[k];
    const double gap = d.norm();
    if (gap > max_gap_m) continue;
    const int steps = static_cast<int>(std::ceil(gap / step_m));
    for (int i = 1; i < steps; ++i) out.push_back(points[k] + d * (static_cast<double>(i) / steps));
  }
  return out;
}

double overlapFraction(const PointCloud& reference, const PointCloud& query,
                       const core::Pose2& query_pose, double distance_m) {
  if (query.empty() || reference.empty()) return 0.0;
  return overlapIn(pointsMap(reference), query, query_pose, distance_m);
}

}  // namespace rrr_graphslam::frontend
