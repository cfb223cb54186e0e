#pragma once
// The multi-resolution max-grids of branch-and-bound scan matching (Olson, "Real-time correlative
// scan matching", ICRA 2009; Hess et al., "Real-time loop closure in 2D LIDAR SLAM", ICRA 2016).
//
// Level h holds, for every cell c of the match grid, the largest value of the 2^h x 2^h block of
// cells that starts at c:
//     P_h(x, y) = max { M(x + i, y + j) : 0 <= i, j < 2^h }
// so that summing P_h over a scan's cells bounds from above the score of every translation in the
// block [dx, dx + 2^h) x [dy, dy + 2^h). Values are probabilities quantized to 0..255 (a byte per
// cell per level keeps a finished submap's stack small). Cells whose block lies wholly outside the
// match grid read the grid's `unknown`.

#include <cstdint>
#include <vector>

#include "rrr_graphslam/frontend/match_grid.h"

namespace rrr_graphslam::frontend {

/// Probability -> 0..255 (rounded), the scale of every precomputation grid.
std::uint8_t quantizeProbability(float p);

class PrecomputationGrid {
 public:
  /// Level `height` of `grid`, by sliding-window maxima along rows then columns (O(cells)).
  PrecomputationGrid(const MatchGrid& grid, int height);
  /// Level h + 1 from level h (`finer`), by doubling: a 2^(h+1) block is four 2^h blocks, so
  ///     P_{h+1}(x, y) = max of P_h at (x, y), (x + 2^h, y), (x, y + 2^h), (x + 2^h, y + 2^h)
  /// (along rows, then columns: two maxima per cell). Equal to PrecomputationGrid(grid, h + 1).
  static PrecomputationGrid coarser(const PrecomputationGrid& finer);

  int height() const { return height_; }
  /// P_h(x, y) in match-grid cell indices; any integers are valid.
  std::uint8_t at(int x, int y) const {
    const int i = x + offset_;
    const int j = y + offset_;
    if (i < 0 || j < 0 || i >= width_ || j >= rows_) return unknown_;
    return cells_[static_cast<std::size_t>(j) * static_cast<std::size_t>(width_) +
                  static_cast<std::size_t>(i)];
  }

 private:
  PrecomputationGrid() = default;

  int height_;
  int offset_;  ///< 2^h - 1 cells before the match grid's first one
  int width_;
  int rows_;
  std::uint8_t unknown_;
  std::vector<std::uint8_t> cells_;
};

/// Levels 0 .. depth-1 of one submap (level 0 is the quantized match grid itself).
class PrecomputationGridStack {
 public:
  /// Level 0 from the grid, each further level from the one before (PrecomputationGrid::coarser).
  PrecomputationGridStack(const MatchGrid& grid, int depth);
  int depth() const { return static_cast<int>(levels_.size()); }
  const PrecomputationGrid& level(int h) const { return levels_[static_cast<std::size_t>(h)]; }
  double resolution() const { return resolution_; }
  const Eigen::Vector2d& origin() const { return origin_; }
  /// The match grid cell containing a point.
  Eigen::Array2i cellOf(const Eigen::Vector2d& p) const;

 private:
  std::vector<PrecomputationGrid> levels_;
  double resolution_;
  Eigen::Vector2d origin_;
};

}  // namespace rrr_graphslam::frontend
