#include "rrr_graphslam/frontend/map_render.h"

#include <mrpt/poses/CPose3D.h>

namespace rrr_graphslam::frontend {

mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m) {
  const std::vector<core::Pose2>& map = inputs.poses;
  // Start from the trajectory's bounding box (MRPT grows the grid to fit the rays); the log's
  // odometry origin may lie hundreds of metres away.
  Eigen::Vector2d low(-1.0, -1.0);
  Eigen::Vector2d high(1.0, 1.0);
  if (!map.empty()) {
    low = high = map.front().head<2>();
    for (const auto& x : map) {
      low = low.cwiseMin(x.head<2>());
      high = high.cwiseMax(x.head<2>());
    }
  }
  mrpt::maps::COccupancyGridMap2D grid(
      static_cast<float>(low.x() - 1.0), static_cast<float>(high.x() + 1.0),
      static_cast<float>(low.y() - 1.0), static_cast<float>(high.y() + 1.0),
      static_cast<float>(resolution_m));
  configureInsertion(grid, inputs.insertion);
  for (std::size_t k = 0; k < inputs.scans.size() && k < map.size(); ++k) {
    const core::Pose2& x = map[k];
    grid.insertObservation(*inputs.scans[k], mrpt::poses::CPose3D(x.x(), x.y(), 0.0, x.z(), 0, 0));
  }
  return grid;
}

}  // namespace rrr_graphslam::frontend
