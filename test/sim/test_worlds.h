#pragma once
// Small hand-made worlds for the simulator's tests, and a helper that writes files to the test's
// temporary folder.

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "rrr_graphslam/sim/world.h"

namespace rrr_graphslam::sim::testing {

/// 12 m x 8 m at 0.1 m (origin (-2, -1)): outer walls, an inner wall at x = 4 with a 1.2 m
/// doorway from y = 3 to 4.2, and a 1 m x 1 m pillar at (7.5, 4.5)-(8.5, 5.5).
inline World twoRooms() {
  World w(120, 80, 0.1, Eigen::Vector2d(-2.0, -1.0));
  for (int cy = 0; cy < w.height; ++cy) {
    for (int cx = 0; cx < w.width; ++cx) {
      const Eigen::Vector2d p = w.centerOf(cx, cy);
      const bool rim = cx < 2 || cy < 2 || cx >= w.width - 2 || cy >= w.height - 2;
      const bool wall = p.x() > 4.0 && p.x() < 4.2 && !(p.y() > 3.0 && p.y() < 4.2);
      const bool pillar = p.x() > 7.5 && p.x() < 8.5 && p.y() > 4.5 && p.y() < 5.5;
      if (rim || wall || pillar) w.set(cx, cy, Cell::kOccupied);
    }
  }
  return w;
}

inline std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace rrr_graphslam::sim::testing
