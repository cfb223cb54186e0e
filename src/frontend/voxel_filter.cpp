#include "rrr_graphslam/frontend/voxel_filter.h"

#include <cmath>
#include <cstdint>
#include <unordered_set>

namespace rrr_graphslam::frontend {

PointCloud voxelFilter(const PointCloud& points, double voxel_m) {
  PointCloud kept;
  kept.reserve(points.size());
  std::unordered_set<std::uint64_t> voxels;
  voxels.reserve(points.size());
  for (const auto& p : points) {
    const auto vx = static_cast<std::int64_t>(std::floor(p.x() / voxel_m));
    const auto vy = static_cast<std::int64_t>(std::floor(p.y() / voxel_m));
    // 2^32 voxels per axis: distinct keys for any scan a laser produces.
    const std::uint64_t key =
        (static_cast<std::uint64_t>(vx) << 32) ^ static_cast<std::uint32_t>(vy);
    if (voxels.insert(key).second) kept.push_back(p);
  }
  return kept;
}

PointCloud adaptiveVoxelFilter(const PointCloud& points, double max_voxel_m, int min_points) {
  const auto enough = static_cast<std::size_t>(std::max(min_points, 0));
  if (points.size() <= enough) return points;
  PointCloud coarsest = voxelFilter(points, max_voxel_m);
  if (coarsest.size() >= enough) return coarsest;
  // Bisection on the voxel side: `low` leaves enough points, `high` does not.
  double low = max_voxel_m;
  PointCloud result;
  do {
    low /= 2.0;
    result = voxelFilter(points, low);
  } while (result.size() < enough && low > 1e-4);
  if (result.size() < enough) return points;
  double high = 2.0 * low;
  while (high > 1.1 * low) {
    const double mid = 0.5 * (low + high);
    PointCloud candidate = voxelFilter(points, mid);
    if (candidate.size() >= enough) {
      low = mid;
      result = std::move(candidate);
    } else {
      high = mid;
    }
  }
  return result;
}

}  // namespace rrr_graphslam::frontend
