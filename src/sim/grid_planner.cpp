#include "rrr_graphslam/sim/grid_planner.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace rrr_graphslam::sim {
namespace {

constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};

// The octile distance: the length of the shortest 8-connected path with no obstacle, a lower
// bound of every path's cost since no step costs less than its length.
double octile(const Eigen::Vector2i& a, const Eigen::Vector2i& b, double resolution_m) {
  const int dx = std::abs(a.x() - b.x()), dy = std::abs(a.y() - b.y());
  return resolution_m * (std::max(dx, dy) + (M_SQRT2 - 1.0) * std::min(dx, dy));
}

}  // namespace

double GridPlanner::stepCost(int cx, int cy, int dx, int dy) const {
  const double length = (dx != 0 && dy != 0 ? M_SQRT2 : 1.0) * clearance_.resolution_m();
  const double c = clearance_.at(cx + dx, cy + dy);
  const double span = std::max(params_.comfort_m - params_.clearance_m, 1e-9);
  const double nearness = std::clamp((params_.comfort_m - c) / span, 0.0, 1.0);
  return length * (1.0 + params_.wall_cost * nearness);
}

std::optional<std::vector<Eigen::Vector2i>> GridPlanner::plan(const Eigen::Vector2i& start,
                                                              const Eigen::Vector2i& goal,
                                                              bool use_heuristic) const {
  if (!traversable(start.x(), start.y()) || !traversable(goal.x(), goal.y())) return std::nullopt;
  const int width = clearance_.width();
  const auto index = [width](int cx, int cy) {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(cx);
  };
  const std::size_t cells =
      static_cast<std::size_t>(width) * static_cast<std::size_t>(clearance_.height());
  std::vector<double> g(cells, std::numeric_limits<double>::infinity());
  std::vector<std::size_t> parent(cells, cells);
  using Item = std::pair<double, std::size_t>;  // f = g + h, cell index
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  const auto h = [&](int cx, int cy) {
    return use_heuristic ? octile({cx, cy}, goal, clearance_.resolution_m()) : 0.0;
  };
  g[index(start.x(), start.y())] = 0.0;
  open.emplace(h(start.x(), start.y()), index(start.x(), start.y()));
  const std::size_t goal_index = index(goal.x(), goal.y());
  while (!open.empty()) {
    const auto [f, i] = open.top();
    open.pop();
    const int cx = static_cast<int>(i % static_cast<std::size_t>(width));
    const int cy = static_cast<int>(i / static_cast<std::size_t>(width));
    if (f > g[i] + h(cx, cy) + 1e-12) continue;  // a stale entry
    if (i == goal_index) break;
    for (int k = 0; k < 8; ++k) {
      const int nx = cx + kDx[k], ny = cy + kDy[k];
      if (!traversable(nx, ny)) continue;
      // No corner cutting: a diagonal step needs both cells beside it.
      if (kDx[k] != 0 && kDy[k] != 0 && (!traversable(nx, cy) || !traversable(cx, ny))) continue;
      const std::size_t j = index(nx, ny);
      const double candidate = g[i] + stepCost(cx, cy, kDx[k], kDy[k]);
      if (candidate < g[j]) {
        g[j] = candidate;
        parent[j] = i;
        open.emplace(candidate + h(nx, ny), j);
      }
    }
  }
  if (!std::isfinite(g[goal_index])) return std::nullopt;
  std::vector<Eigen::Vector2i> path;
  for (std::size_t i = goal_index; i != cells; i = parent[i]) {
    path.emplace_back(static_cast<int>(i % static_cast<std::size_t>(width)),
                      static_cast<int>(i / static_cast<std::size_t>(width)));
  }
  std::reverse(path.begin(), path.end());
  return path;
}

double GridPlanner::cost(const std::vector<Eigen::Vector2i>& path) const {
  double total = 0.0;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const Eigen::Vector2i d = path[k] - path[k - 1];
    total += stepCost(path[k - 1].x(), path[k - 1].y(), d.x(), d.y());
  }
  return total;
}

std::vector<Eigen::Vector2i> GridPlanner::reachable(const Eigen::Vector2i& start) const {
  const int width = clearance_.width();
  std::vector<char> seen(
      static_cast<std::size_t>(width) * static_cast<std::size_t>(clearance_.height()), 0);
  const auto index = [width](int cx, int cy) {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(cx);
  };
  std::vector<Eigen::Vector2i> out;
  if (!traversable(start.x(), start.y())) return out;
  std::vector<Eigen::Vector2i> stack{start};
  seen[index(start.x(), start.y())] = 1;
  while (!stack.empty()) {
    const Eigen::Vector2i c = stack.back();
    stack.pop_back();
    out.push_back(c);
    for (int k = 0; k < 4; ++k) {
      const int nx = c.x() + kDx[k], ny = c.y() + kDy[k];
      if (!traversable(nx, ny) || seen[index(nx, ny)]) continue;
      seen[index(nx, ny)] = 1;
      stack.emplace_back(nx, ny);
    }
  }
  std::sort(out.begin(), out.end(), [](const Eigen::Vector2i& a, const Eigen::Vector2i& b) {
    return a.y() != b.y() ? a.y() < b.y() : a.x() < b.x();
  });
  return out;
}

}  // namespace rrr_graphslam::sim
