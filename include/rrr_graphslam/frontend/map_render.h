#pragma once
// The occupancy map of a laser SLAM run: every node's scan inserted at its map pose. Its inputs
// are a value that shares the scans, so another thread can render it while SLAM goes on.
//
// Layering: with every scan in one grid (kAllScans) a cell's occupancy weighs every observation
// of it alike, so where the world changed between sessions the sessions that saw the old state
// outvote the newest. kNewestSession renders each session on its own and takes each cell from
// the newest session that decided it (occupied or free by map_server's default thresholds): the map
// shows the world as the last robot to look saw it (a lifelong map's choice; within a session the
// world is taken to be still).

#include <memory>
#include <string>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

enum class MapLayering { kAllScans, kNewestSession };

inline core::Choices<MapLayering> choices(MapLayering /*tag*/) {
  return {{MapLayering::kAllScans, "all"}, {MapLayering::kNewestSession, "newest-session"}};
}

struct MapInputs {
  std::vector<core::Pose2> poses;  ///< map pose of every node
  std::vector<std::shared_ptr<const mrpt::obs::CObservation2DRangeScan>> scans;  ///< per node
  SubmapParams insertion;     ///< how a scan is inserted (ranges, occupancy probabilities)
  std::vector<int> sessions;  ///< per node, for kNewestSession (empty: one session)
  MapLayering layering = MapLayering::kAllScans;
};

/// "all" or "newest-session".
std::string toString(MapLayering layering);
/// Parses "all" or "newest-session"; std::invalid_argument otherwise.
MapLayering parseMapLayering(const std::string& text);

/// The grid spans the trajectory's bounding box and grows to fit the rays.
mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m);

}  // namespace rrr_graphslam::frontend
