#pragma once
// Map outputs: the map_server pair (PGM + YAML, as map_saver writes them) and a PNG picture with
// the trajectory and the loop candidates (accepted green, rejected red). Every file is written
// atomically (temporary file + rename).

#include <string>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

struct MapServerThresholds {
  double occupied = 0.65;  ///< map_server's occupied_thresh
  double free = 0.196;     ///< map_server's free_thresh
};

/// map_server's trinary value of a cell from its occupancy probability: 0 occupied, 254 free,
/// 205 unknown. (MRPT's getCell() is the probability of being free: pass 1 - getCell().)
unsigned char mapServerPixel(float probability, const MapServerThresholds& thresholds = {});

/// Writes BASE.pgm and BASE.yaml (image path relative to the YAML, origin at the grid's lower-left
/// corner). Throws std::runtime_error naming the file on failure.
void writeMapServerFiles(const mrpt::maps::COccupancyGridMap2D& grid, const std::string& base,
                         const MapServerThresholds& thresholds = {});

struct LoopLine {
  core::Pose2 from;
  core::Pose2 to;
  bool accepted;
};

/// A picture of the map (grey levels of the probabilities), the trajectory in blue and the loop
/// candidates as lines. Throws std::runtime_error naming the file on failure.
void writeMapPng(const mrpt::maps::COccupancyGridMap2D& grid, const std::string& path,
                 const std::vector<core::Pose2>& trajectory, const std::vector<LoopLine>& loops);

}  // namespace rrr_graphslam::frontend
