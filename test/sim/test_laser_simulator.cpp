// MRPT's laser simulator against a slow, obviously correct ray march over the world's cells, the
// beam layout, and the range noise.

#include <gtest/gtest.h>

#include <cmath>

#include "rrr_graphslam/sim/laser_simulator.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

// The first solid cell along the ray, marched in steps of a twentieth of a cell.
double marchRay(const World& w, const Eigen::Vector2d& from, double angle, double max_range) {
  const double step = w.resolution_m / 20.0;
  const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
  for (double r = 0.0; r < max_range; r += step) {
    const Eigen::Vector2i c = w.cellOf(from + r * d);
    if (!w.isFree(c.x(), c.y())) return r;
  }
  return max_range;
}

TEST(LaserSimulator, AgreesWithARayMarchThroughTheWorld) {
  const World w = testing::twoRooms();
  LaserParams params;
  params.max_range_m = 5.0;  // some beams see nothing within it
  const LaserSimulator laser(w, params);
  std::size_t compared = 0, close = 0, near_limit = 0, misses = 0, agree = 0;
  for (const core::Pose2& x : {core::Pose2(0.0, 3.0, 0.0), core::Pose2(2.0, 1.0, 2.5),
                               core::Pose2(6.5, 5.0, -0.7), core::Pose2(9.0, 2.0, M_PI)}) {
    const std::vector<float> ranges = laser.scan(x, nullptr);
    ASSERT_EQ(ranges.size(), 181U);
    for (std::size_t i = 0; i < ranges.size(); ++i) {
      const double angle = x.z() + params.angle_min_rad + i * params.angle_increment_rad;
      const double expected = marchRay(w, x.head<2>(), angle, params.max_range_m);
      if (expected >= params.max_range_m - 0.05) {
        ++near_limit;
        const bool miss = ranges[i] == static_cast<float>(params.max_range_m);
        misses += miss;
        agree += miss || std::abs(ranges[i] - expected) < 0.01;
        continue;
      }
      ++compared;
      close += std::abs(ranges[i] - expected) < 0.01;
    }
  }
  // Beams beyond the limit read max_range (those just inside it may read either); the others
  // agree to a centimetre but for one or two that graze a corner MRPT's steps clip.
  EXPECT_GT(misses, 200U);
  EXPECT_EQ(agree, near_limit);
  EXPECT_GE(static_cast<double>(close), 0.99 * static_cast<double>(compared));
}

TEST(LaserSimulator, BeamsFanCounterClockwiseFromTheRight) {
  const World w = testing::twoRooms();
  const LaserSimulator laser(w, LaserParams{});
  // At (0, 2) facing +x: the inner wall 4 m ahead, the outer walls (inner faces at y = -0.8
  // and 6.8) 2.8 m to the right (beam 0) and 4.8 m to the left (beam 180).
  const std::vector<float> r = laser.scan({0.0, 2.0, 0.0}, nullptr);
  EXPECT_NEAR(r[90], 4.0, 0.01);
  EXPECT_NEAR(r[0], 2.8, 0.01);
  EXPECT_NEAR(r[180], 4.8, 0.01);
  // A laser mounted 0.5 m ahead, turned left by 90 degrees: its middle beam looks along +y.
  LaserParams mounted;
  mounted.laser_in_robot = {0.5, 0.0, M_PI / 2};
  const std::vector<float> m = LaserSimulator(w, mounted).scan({0.0, 2.0, 0.0}, nullptr);
  EXPECT_NEAR(m[90], 4.8, 0.01);
  EXPECT_NEAR(m[0], 3.5, 0.01);  // to the robot's front: the inner wall, 3.5 m from the laser
}

TEST(LaserSimulator, RangeNoiseHasTheGivenSpread) {
  const World w = testing::twoRooms();
  LaserParams params;
  params.range_stddev_m = 0.02;
  const LaserSimulator laser(w, params);
  const core::Pose2 x(1.0, 2.0, 0.3);
  const std::vector<float> clean = laser.scan(x, nullptr);
  std::mt19937_64 rng(7);
  double sum = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  for (int k = 0; k < 50; ++k) {
    const std::vector<float> noisy = laser.scan(x, &rng);
    for (std::size_t i = 0; i < noisy.size(); ++i) {
      ASSERT_LT(noisy[i], static_cast<float>(params.max_range_m));
      const double e = noisy[i] - clean[i];
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  const double mean = sum / n;
  EXPECT_NEAR(mean, 0.0, 0.002);
  EXPECT_NEAR(std::sqrt(sum2 / n - mean * mean), 0.02, 0.002);
}

}  // namespace
}  // namespace rrr_graphslam::sim
