#include "rrr_graphslam/frontend/match_grid.h"

#include <algorithm>
#include <stdexcept>

#include <mrpt/maps/COccupancyGridMap2D.h>

namespace rrr_graphslam::frontend {

MatchGrid::MatchGrid(const Eigen::Vector2d& origin, double resolution, int width, int height,
                     float unknown)
    : origin_(origin),
      resolution_(resolution),
      width_(width),
      height_(height),
      unknown_(unknown),
      values_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), unknown) {
  if (!(resolution > 0.0) || width < 0 || height < 0) {
    throw std::invalid_argument("MatchGrid: resolution must be positive and sizes non-negative");
  }
}

MatchGrid MatchGrid::maxPooled(int factor) const {
  if (factor <= 1) return *this;
  MatchGrid pooled(origin_, factor * resolution_, (width_ + factor - 1) / factor,
                   (height_ + factor - 1) / factor, unknown_);
  for (int y = 0; y < pooled.height(); ++y) {
    for (int x = 0; x < pooled.width(); ++x) {
      float best = -1.0F;
      for (int j = 0; j < factor; ++j) {
        for (int i = 0; i < factor; ++i) best = std::max(best, at(factor * x + i, factor * y + j));
      }
      pooled.set(x, y, best);
    }
  }
  return pooled;
}

MatchGrid MatchGrid::fromOccupancyGrid(const mrpt::maps::COccupancyGridMap2D& grid, float unknown) {
  using Grid = mrpt::maps::COccupancyGridMap2D;
  MatchGrid out({grid.getXMin(), grid.getYMin()}, grid.getResolution(),
                static_cast<int>(grid.getSizeX()), static_cast<int>(grid.getSizeY()), unknown);
  const auto& raw = grid.getRawMap();
  for (std::size_t k = 0; k < raw.size(); ++k) {
    // MRPT stores rows of x, like ours, and the probability of being FREE.
    if (raw[k] != 0) out.values_[k] = 1.0F - Grid::l2p(raw[k]);
  }
  return out;
}

float MatchGrid::interpolate(const Eigen::Vector2d& p, Eigen::Vector2d* gradient) const {
  // Continuous cell coordinates with cell centres at integers.
  const double u = (p.x() - origin_.x()) / resolution_ - 0.5;
  const double v = (p.y() - origin_.y()) / resolution_ - 0.5;
  const int x0 = static_cast<int>(std::floor(u));
  const int y0 = static_cast<int>(std::floor(v));
  const double fu = u - x0;
  const double fv = v - y0;
  const double v00 = at(x0, y0);
  const double v10 = at(x0 + 1, y0);
  const double v01 = at(x0, y0 + 1);
  const double v11 = at(x0 + 1, y0 + 1);
  const double bottom = v00 + fu * (v10 - v00);
  const double top = v01 + fu * (v11 - v01);
  if (gradient != nullptr) {
    const double d_du = (1.0 - fv) * (v10 - v00) + fv * (v11 - v01);
    const double d_dv = top - bottom;
    *gradient = Eigen::Vector2d(d_du, d_dv) / resolution_;
  }
  return static_cast<float>(bottom + fv * (top - bottom));
}

}  // namespace rrr_graphslam::frontend
