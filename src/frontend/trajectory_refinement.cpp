#include "rrr_graphslam/frontend/trajectory_refinement.h"

#include <stdexcept>

namespace rrr_graphslam::frontend {

std::vector<core::Pose2> refineTrajectory(const MatchGrid& map,
                                          const std::vector<PointCloud>& points,
                                          const std::vector<core::Pose2>& poses,
                                          const TrajectoryRefinementParams& params) {
  if (points.size() != poses.size()) {
    throw std::invalid_argument("refineTrajectory: " + std::to_string(points.size()) +
                                " scans but " + std::to_string(poses.size()) + " poses");
  }
  std::vector<core::Pose2> refined = poses;
  const auto n = static_cast<long>(poses.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (long k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (static_cast<int>(points[i].size()) < params.min_points) continue;
    refined[i] = refineLeastSquares(map, poses[i], poses[i], points[i], params.least_squares).pose;
  }
  return refined;
}

}  // namespace rrr_graphslam::frontend
