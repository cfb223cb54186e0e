// Voxel filters: the plain filter against its definition (first point of each voxel, order kept),
// the adaptive one against what it promises (enough points, the coarsest voxel within 10%).

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rrr_graphslam/frontend/voxel_filter.h"

namespace rrr_graphslam::frontend {
namespace {

PointCloud randomCloud(int n, double extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-extent, extent);
  PointCloud cloud;
  for (int k = 0; k < n; ++k) cloud.emplace_back(u(rng), u(rng));
  return cloud;
}

// The definition, slowly: a point is kept if no kept point shares its voxel.
PointCloud voxelFilterSlow(const PointCloud& points, double voxel) {
  PointCloud kept;
  auto cell = [voxel](const Eigen::Vector2d& p) {
    return Eigen::Vector2d(std::floor(p.x() / voxel), std::floor(p.y() / voxel));
  };
  for (const auto& p : points) {
    bool taken = false;
    for (const auto& q : kept) taken = taken || cell(q) == cell(p);
    if (!taken) kept.push_back(p);
  }
  return kept;
}

TEST(VoxelFilter, KeepsTheFirstPointOfEachVoxelInOrder) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const PointCloud cloud = randomCloud(400, 3.0, seed);  // negative coordinates included
    for (double voxel : {0.05, 0.3, 1.0}) {
      EXPECT_EQ(voxelFilter(cloud, voxel), voxelFilterSlow(cloud, voxel))
          << "seed " << seed << " voxel " << voxel;
    }
  }
}

TEST(AdaptiveVoxelFilter, FindsTheCoarsestVoxelThatLeavesEnoughPoints) {
  // A 10 m wall sampled every centimetre: n(v) is about 10 / v points.
  PointCloud wall;
  for (int k = 0; k < 1000; ++k) wall.emplace_back(0.01 * k + 0.005, 0.3);
  const PointCloud thinned = adaptiveVoxelFilter(wall, 0.9, 100);
  EXPECT_GE(thinned.size(), 100U);
  EXPECT_LE(thinned.size(), 115U);  // the voxel is within 10% of the coarsest that works

  // Coarse enough already at the largest voxel: that filter's result.
  const PointCloud spread = randomCloud(300, 50.0, 7);
  EXPECT_EQ(adaptiveVoxelFilter(spread, 0.9, 100), voxelFilter(spread, 0.9));

  // Small clouds are left alone, and a cloud that no voxel thins enough is returned whole.
  const PointCloud few = randomCloud(80, 2.0, 3);
  EXPECT_EQ(adaptiveVoxelFilter(few, 0.9, 100), few);
  const PointCloud same(150, Eigen::Vector2d(1.0, 2.0));
  EXPECT_EQ(adaptiveVoxelFilter(same, 0.9, 100), same);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
