// Odometry drift: exact without noise, the same for the same seed, and a random walk whose spread
// grows with the square root of the distance whatever the sampling rate.

#include <gtest/gtest.h>

#include <cmath>

#include "rrr_graphslam/sim/odometry_model.h"

namespace rrr_graphslam::sim {
namespace {

std::vector<core::Pose2> straightLine(double length_m, int steps) {
  std::vector<core::Pose2> truth;
  for (int k = 0; k <= steps; ++k) truth.emplace_back(length_m * k / steps, 0.0, 0.0);
  return truth;
}

TEST(OdometryModel, ZeroNoiseGivesTheTruthInTheOdometryFrame) {
  std::vector<core::Pose2> truth;
  for (int k = 0; k < 200; ++k) {
    truth.emplace_back(std::cos(0.05 * k) * 3.0, std::sin(0.07 * k) * 2.0,
                       core::normalizeAngle(3.1 + 0.11 * k));  // crosses +-pi
  }
  const core::Pose2 start(40.0, -12.0, -2.5);
  std::mt19937_64 rng(1);
  const auto odometry = simulateOdometry(truth, start, OdometryNoise{0, 0, 0, 0}, rng);
  ASSERT_EQ(odometry.size(), truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const core::Pose2 expected = core::compose(start, core::between(truth[0], truth[k]));
    EXPECT_NEAR(odometry[k].x(), expected.x(), 1e-9);
    EXPECT_NEAR(odometry[k].y(), expected.y(), 1e-9);
    EXPECT_NEAR(core::normalizeAngle(odometry[k].z() - expected.z()), 0.0, 1e-9);
  }
}

TEST(OdometryModel, TheSameSeedGivesTheSameReadings) {
  const auto truth = straightLine(5.0, 50);
  std::mt19937_64 a(3), b(3), c(4);
  const auto ra = simulateOdometry(truth, core::Pose2::Zero(), OdometryNoise{}, a);
  EXPECT_EQ(ra, simulateOdometry(truth, core::Pose2::Zero(), OdometryNoise{}, b));
  EXPECT_NE(ra, simulateOdometry(truth, core::Pose2::Zero(), OdometryNoise{}, c));
}

TEST(OdometryModel, DriftGrowsWithTheSquareRootOfDistanceAtAnyRate) {
  OdometryNoise noise{0.05, 0.0, 0.0, 0.0};  // along-track only
  for (const int steps : {20, 400}) {
    SCOPED_TRACE(steps);
    std::mt19937_64 rng(11);
    const auto truth = straightLine(16.0, steps);
    double sum2 = 0.0;
    const int runs = 2000;
    for (int r = 0; r < runs; ++r) {
      const auto odometry = simulateOdometry(truth, core::Pose2::Zero(), noise, rng);
      const double e = odometry.back().x() - 16.0;
      sum2 += e * e;
    }
    // 0.05 m per sqrt(m) over 16 m: 0.2 m.
    EXPECT_NEAR(std::sqrt(sum2 / runs), 0.2, 0.012);
  }
}

}  // namespace
}  // namespace rrr_graphslam::sim
