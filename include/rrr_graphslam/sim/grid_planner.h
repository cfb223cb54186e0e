#pragma once
// Paths through a world's free space: A* (Hart, Nilsson and Raphael 1968) on the 8-neighbourhood
// of the cells whose clearance is at least `clearance_m` (the world inflated by the robot), with
// a cost that grows near walls so that paths keep to the middle of corridors, as a navigation
// stack's costmap makes them. Written out rather than through Boost.Graph's astar_search: on a
// grid the explicit loop is shorter than the graph adaptors, visitor and early-exit exception it
// needs.

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/sim/clearance_map.h"

namespace rrr_graphslam::sim {

struct PlannerParams {
  /// m; cells nearer than this to a solid cell are never entered (default 0.35: a robot of radius
  /// 0.3 m with a margin).
  double clearance_m = 0.35;
  /// m; below this clearance a step costs more (default 1.0).
  double comfort_m = 1.0;
  /// A step at the minimum clearance costs (1 + this) times its length, falling linearly to 1 at
  /// comfort_m (default 3).
  double wall_cost = 3.0;
};

class GridPlanner {
 public:
  GridPlanner(const ClearanceMap& clearance, const PlannerParams& params)
      : clearance_(clearance), params_(params) {}

  /// Whether the robot's centre may stand in the cell.
  bool traversable(int cx, int cy) const { return clearance_.at(cx, cy) >= params_.clearance_m; }
  /// The cells, start to goal, of the cheapest path; nullopt when the goal cannot be reached or
  /// either end is not traversable. `use_heuristic` false makes it Dijkstra (for tests).
  std::optional<std::vector<Eigen::Vector2i>> plan(const Eigen::Vector2i& start,
                                                   const Eigen::Vector2i& goal,
                                                   bool use_heuristic = true) const;
  /// The cost of a path plan() returned.
  double cost(const std::vector<Eigen::Vector2i>& path) const;
  /// Every traversable cell reachable from `start` (its connected component), row-major order.
  std::vector<Eigen::Vector2i> reachable(const Eigen::Vector2i& start) const;

 private:
  double stepCost(int cx, int cy, int dx, int dy) const;

  const ClearanceMap& clearance_;
  PlannerParams params_;
};

}  // namespace rrr_graphslam::sim
