#pragma once
// The occupancy map of a laser SLAM run: every node's scan inserted at its map pose. Its inputs
// are a value that shares the scans, so another thread can render it while SLAM goes on.

#include <memory>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

struct MapInputs {
  std::vector<core::Pose2> poses;  ///< map pose of every node
  std::vector<std::shared_ptr<const mrpt::obs::CObservation2DRangeScan>> scans;  ///< per node
  SubmapParams insertion;  ///< how a scan is inserted (ranges, occupancy probabilities)
};

/// The grid spans the trajectory's bounding box and grows to fit the rays.
mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m);

}  // namespace rrr_graphslam::frontend
