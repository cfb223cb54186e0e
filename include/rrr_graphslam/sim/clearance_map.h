#pragma once
// The clearance of every cell of a world: the distance from its centre to the centre of the
// nearest solid cell (occupied, unknown or beyond the grid's edge; the gap to that cell's face is
// half a cell less). Computed by a brushfire (multi-source Dijkstra on
// the 8-neighbourhood), which overestimates the Euclidean distance by at most 8% (the octile
// metric); the planner keeps paths this far from walls and the waypoints are drawn from it.

#include <cstddef>
#include <vector>

#include "rrr_graphslam/sim/world.h"

namespace rrr_graphslam::sim {

class ClearanceMap {
 public:
  explicit ClearanceMap(const World& world);

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution_m() const { return resolution_m_; }
  /// 0 for a solid cell and for a cell outside the grid.
  double at(int cx, int cy) const {
    if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) return 0.0;
    return distance_m_[index(cx, cy)];
  }

 private:
  std::size_t index(int cx, int cy) const {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(width_) +
           static_cast<std::size_t>(cx);
  }

  int width_;
  int height_;
  double resolution_m_;
  std::vector<double> distance_m_;
};

}  // namespace rrr_graphslam::sim
