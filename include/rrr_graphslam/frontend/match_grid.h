#pragma once
// A submap's occupancy probabilities as scan matching reads them: a dense float grid in the
// submap's (local SLAM) frame. Cells never observed, and everything outside the grid, read as
// `unknown`: a scan is not rewarded for reaching into space the submap has not seen.
//
// Cell (i, j) covers [origin.x + i * resolution, origin.x + (i + 1) * resolution) in x (same in y).

#include <cmath>
#include <vector>

#include <Eigen/Core>

namespace mrpt::maps {
class COccupancyGridMap2D;
}

namespace rrr_graphslam::frontend {

class MatchGrid {
 public:
  MatchGrid() = default;
  MatchGrid(const Eigen::Vector2d& origin, double resolution, int width, int height, float unknown);
  /// Occupancy probabilities of an MRPT grid (which stores the probability of being free); cells
  /// at exactly 0.5 (never updated) read `unknown`.
  static MatchGrid fromOccupancyGrid(const mrpt::maps::COccupancyGridMap2D& grid, float unknown);
  /// The grid at `factor` times the cell size, each cell the largest of the factor x factor cells
  /// it covers (same origin; a partial block at the far edges is padded with `unknown`).
  MatchGrid maxPooled(int factor) const;

  const Eigen::Vector2d& origin() const { return origin_; }
  double resolution() const { return resolution_; }
  int width() const { return width_; }
  int height() const { return height_; }
  float unknown() const { return unknown_; }

  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }
  float at(int x, int y) const { return contains(x, y) ? values_[index(x, y)] : unknown_; }
  void set(int x, int y, float value) { values_[index(x, y)] = value; }

  /// The cell containing a point.
  Eigen::Array2i cellOf(const Eigen::Vector2d& p) const {
    return {static_cast<int>(std::floor((p.x() - origin_.x()) / resolution_)),
            static_cast<int>(std::floor((p.y() - origin_.y()) / resolution_))};
  }
  /// Bilinear interpolation between cell centres, with its gradient (per metre) in `gradient`.
  float interpolate(const Eigen::Vector2d& p, Eigen::Vector2d* gradient = nullptr) const;

 private:
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) +
           static_cast<std::size_t>(x);
  }

  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  double resolution_ = 0.05;
  int width_ = 0;
  int height_ = 0;
  float unknown_ = 0.1F;
  std::vector<float> values_;
};

}  // namespace rrr_graphslam::frontend
