// The clearance map against brute force, and A* against Dijkstra (the same search without its
// heuristic) on a two-room world.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rrr_graphslam/sim/clearance_map.h"
#include "rrr_graphslam/sim/grid_planner.h"
#include "rrr_graphslam/sim/world_changes.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

// Distance from a cell's centre to the nearest solid cell's centre, the cells beyond the grid's
// edge included.
double bruteForceClearance(const World& w, int cx, int cy) {
  double best = std::numeric_limits<double>::infinity();
  for (int y = -1; y <= w.height; ++y) {
    for (int x = -1; x <= w.width; ++x) {
      if (w.isFree(x, y)) continue;
      best = std::min(best, std::hypot(x - cx, y - cy) * w.resolution_m);
    }
  }
  return best;
}

TEST(ClearanceMap, WithinTheOctileBoundOfTheEuclideanDistance) {
  const World w = testing::twoRooms();
  const ClearanceMap map(w);
  for (int cy = 0; cy < w.height; cy += 3) {
    for (int cx = 0; cx < w.width; cx += 3) {
      const double exact = bruteForceClearance(w, cx, cy);
      EXPECT_GE(map.at(cx, cy), exact - 1e-9) << cx << "," << cy;
      EXPECT_LE(map.at(cx, cy), 1.0824 * exact + 1e-9) << cx << "," << cy;
    }
  }
  EXPECT_EQ(map.at(-1, 0), 0.0);
}

TEST(GridPlanner, AStarPathIsFreeConnectedAndAsCheapAsDijkstra) {
  const World w = testing::twoRooms();
  const ClearanceMap map(w);
  const PlannerParams params;
  const GridPlanner planner(map, params);
  const Eigen::Vector2i start = w.cellOf({0.0, 0.5});
  const Eigen::Vector2i goal = w.cellOf({8.0, 2.0});  // in the other room
  const auto path = planner.plan(start, goal);
  ASSERT_TRUE(path.has_value());
  EXPECT_EQ(path->front(), start);
  EXPECT_EQ(path->back(), goal);
  bool through_door = false;
  for (std::size_t k = 0; k < path->size(); ++k) {
    const Eigen::Vector2i& c = (*path)[k];
    EXPECT_GE(map.at(c.x(), c.y()), params.clearance_m);
    EXPECT_GE(bruteForceClearance(w, c.x(), c.y()), params.clearance_m / 1.0824);
    if (k > 0) {
      EXPECT_EQ(((*path)[k] - (*path)[k - 1]).cwiseAbs().maxCoeff(), 1);
    }
    const Eigen::Vector2d p = w.centerOf(c.x(), c.y());
    through_door = through_door || (std::abs(p.x() - 4.1) < 0.1 && p.y() > 3.0 && p.y() < 4.2);
  }
  EXPECT_TRUE(through_door);
  const auto dijkstra = planner.plan(start, goal, false);
  ASSERT_TRUE(dijkstra.has_value());
  EXPECT_NEAR(planner.cost(*path), planner.cost(*dijkstra), 1e-9);
  // The wall cost keeps the path off the walls: dearer than the straightest free path.
  EXPECT_GT(planner.cost(*path), 0.1 * static_cast<double>(path->size()));
}

TEST(GridPlanner, AClosedDoorSplitsTheRooms) {
  World w = testing::twoRooms();
  WorldChange door;
  door.kind = WorldChange::Kind::kDoor;
  door.from_m = {4.1, 2.9};
  door.to_m = {4.1, 4.3};
  const World drawn = w;
  applyChange(w, door, drawn);
  const ClearanceMap map(w);
  const GridPlanner planner(map, PlannerParams{});
  const Eigen::Vector2i start = w.cellOf({0.0, 0.5});
  EXPECT_FALSE(planner.plan(start, w.cellOf({8.0, 2.0})).has_value());
  const auto left = planner.reachable(start);
  ASSERT_FALSE(left.empty());
  for (const Eigen::Vector2i& c : left) EXPECT_LT(w.centerOf(c.x(), c.y()).x(), 4.0);
  // A start that is not traversable: no path, nothing reachable.
  EXPECT_FALSE(planner.plan(w.cellOf({-1.9, 0.0}), start).has_value());
  EXPECT_TRUE(planner.reachable(w.cellOf({-1.9, 0.0})).empty());
}

}  // namespace
}  // namespace rrr_graphslam::sim
