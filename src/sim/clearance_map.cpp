#include "rrr_graphslam/sim/clearance_map.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace rrr_graphslam::sim {

ClearanceMap::ClearanceMap(const World& world)
    : width_(world.width),
      height_(world.height),
      resolution_m_(world.resolution_m),
      distance_m_(world.cells.size(), std::numeric_limits<double>::infinity()) {
  using Item = std::pair<double, std::size_t>;  // distance, cell index
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  // Seeds: solid cells at 0; a free cell at most its distance to the grid's edge (a solid rim).
  for (int cy = 0; cy < height_; ++cy) {
    for (int cx = 0; cx < width_; ++cx) {
      const std::size_t i = index(cx, cy);
      const int to_edge = std::min({cx, cy, width_ - 1 - cx, height_ - 1 - cy}) + 1;
      distance_m_[i] = world.at(cx, cy) == Cell::kFree ? to_edge * resolution_m_ : 0.0;
      queue.emplace(distance_m_[i], i);
    }
  }
  while (!queue.empty()) {
    const auto [d, i] = queue.top();
    queue.pop();
    if (d > distance_m_[i]) continue;
    const int cx = static_cast<int>(i % static_cast<std::size_t>(width_));
    const int cy = static_cast<int>(i / static_cast<std::size_t>(width_));
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = cx + dx, ny = cy + dy;
        if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width_ || ny >= height_) continue;
        const double step = (dx != 0 && dy != 0 ? M_SQRT2 : 1.0) * resolution_m_;
        const std::size_t j = index(nx, ny);
        if (d + step < distance_m_[j]) {
          distance_m_[j] = d + step;
          queue.emplace(distance_m_[j], j);
        }
      }
    }
  }
}

}  // namespace rrr_graphslam::sim
