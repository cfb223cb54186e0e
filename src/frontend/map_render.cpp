#include "rrr_graphslam/frontend/map_render.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/frontend/map_io.h"

namespace rrr_graphslam::frontend {
namespace {
constexpr unsigned char kUnknownPixel = 205;  // map_io.h's mapServerPixel
}  // namespace

void validate(const MapRenderParams& params) {
  forEachMapRenderParam(params, [](const core::ParamInfo& info, const auto& value) {
    core::checkRange(info, value);
  });
}

mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m) {
  if (inputs.render) validate(*inputs.render);
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
  SubmapParams insertion = inputs.insertion;
  if (inputs.render) {
    insertion.hit_probability = static_cast<float>(inputs.render->hit_probability);
    insertion.miss_probability = static_cast<float>(inputs.render->miss_probability);
  }
  configureInsertion(grid, insertion);
  const std::size_t nodes = std::min(inputs.scans.size(), map.size());
  auto insert = [&](mrpt::maps::COccupancyGridMap2D& into, std::size_t k) {
    const core::Pose2& x = map[k];
    into.insertObservation(*inputs.scans[k], mrpt::poses::CPose3D(x.x(), x.y(), 0.0, x.z(), 0, 0));
  };
  for (std::size_t k = 0; k < nodes; ++k) insert(grid, k);
  if (inputs.layering == MapLayering::kAllScans || inputs.sessions.size() < nodes) return grid;
  const int first = *std::min_element(inputs.sessions.begin(), inputs.sessions.begin() + nodes);
  const int last = *std::max_element(inputs.sessions.begin(), inputs.sessions.begin() + nodes);
  if (first == last) return grid;

  // Newest session first; a cell keeps the first (newest) session's state that observed it. Every
  // session's grid has the whole map's bounds (the rays already fit in them).
  mrpt::maps::COccupancyGridMap2D layered = grid;
  std::vector<char> taken(static_cast<std::size_t>(grid.getSizeX()) * grid.getSizeY(), 0);
  for (int session = last; session >= first; --session) {
    mrpt::maps::COccupancyGridMap2D own(grid.getXMin(), grid.getXMax(), grid.getYMin(),
                                        grid.getYMax(), grid.getResolution());
    configureInsertion(own, insertion);
    bool any = false;
    for (std::size_t k = 0; k < nodes; ++k) {
      if (inputs.sessions[k] != session) continue;
      insert(own, k);
      any = true;
    }
    if (!any || own.getSizeX() != grid.getSizeX() || own.getSizeY() != grid.getSizeY()) continue;
    for (unsigned cy = 0; cy < own.getSizeY(); ++cy) {
      for (unsigned cx = 0; cx < own.getSizeX(); ++cx) {
        char& t = taken[static_cast<std::size_t>(cy) * grid.getSizeX() + cx];
        const float p = own.getCell(cx, cy);
        // Taken by a newer session, or not decided by this one (a map_server reader would see
        // it unknown: a glimpse does not overrule an older session's clear view).
        if (t || mapServerPixel(1.0F - p) == kUnknownPixel) continue;
        layered.setCell(cx, cy, p);
        t = 1;
      }
    }
  }
  return layered;
}

std::string toString(MapLayering layering) { return core::choiceName(layering); }

MapLayering parseMapLayering(const std::string& text) {
  return core::parseChoiceOrThrow<MapLayering>(text, "map layering");
}

}  // namespace rrr_graphslam::frontend
