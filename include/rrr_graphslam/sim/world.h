#pragma once
// A simulated world: a trinary occupancy grid read from and written to map_server's pair of files
// (a YAML with image, resolution, origin, occupied_thresh, free_thresh, negate; a binary PGM).
// Cells follow map_server's reading of a pixel: p = (255 - value) / 255 (value / 255 with
// negate: 1), occupied if p > occupied_thresh, free if p < free_thresh, unknown otherwise. The
// simulator treats unknown cells as solid: a laser beam stops there and no path enters them.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rrr_graphslam::sim {

enum class Cell : std::uint8_t { kFree, kOccupied, kUnknown };

struct World {
  double resolution_m = 0.05;
  /// The lower-left corner of cell (0, 0) in the world frame, m (map_server's origin x, y).
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  int width = 0;   ///< cells along x
  int height = 0;  ///< cells along y
  /// Row by row from the bottom (y up), unlike the image's rows.
  std::vector<Cell> cells;

  World() = default;
  World(int width_cells, int height_cells, double resolution, const Eigen::Vector2d& origin,
        Cell fill = Cell::kFree);

  bool inside(int cx, int cy) const { return cx >= 0 && cy >= 0 && cx < width && cy < height; }
  Cell at(int cx, int cy) const {
    return cells[static_cast<std::size_t>(cy) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(cx)];
  }
  void set(int cx, int cy, Cell c) {
    cells[static_cast<std::size_t>(cy) * static_cast<std::size_t>(width) +
          static_cast<std::size_t>(cx)] = c;
  }
  /// The cell holding a world point (may be outside the grid).
  Eigen::Vector2i cellOf(const Eigen::Vector2d& p_m) const;
  /// The centre of a cell in the world frame.
  Eigen::Vector2d centerOf(int cx, int cy) const;
  /// Free and inside the grid; everything outside the grid counts as solid.
  bool isFree(int cx, int cy) const { return inside(cx, cy) && at(cx, cy) == Cell::kFree; }
  std::size_t count(Cell c) const;
};

/// Reads a map_server world. Throws core::InputError naming the YAML (a missing or bad field, with
/// its line) or the PGM (bad header, with its line, or too few pixels).
World readWorld(const std::string& yaml_path);

/// Writes BASE.pgm and BASE.yaml (free 254, occupied 0, unknown 205, as map_saver writes them),
/// both atomically. Throws std::runtime_error naming the file on failure.
void writeWorld(const World& world, const std::string& base);

}  // namespace rrr_graphslam::sim
