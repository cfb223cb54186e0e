// The odometry step's noise: recovered from absolute covariances that dead reckoning produced,
// refused from ones it could not have produced, and the motion model's scaling.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "rrr_graphslam/core/odometry_noise.h"

namespace rrr_graphslam::core {
namespace {

TEST(OdometryNoise, CompositionJacobiansMatchCentralDifferences) {
  const Pose2 x(1.0, -2.0, 2.9), u(0.7, 0.3, -0.4);
  Eigen::Matrix3d A, B;
  compositionJacobians(x, u, A, B);
  const double h = 1e-6;
  for (int i = 0; i < 3; ++i) {
    Pose2 dx = Pose2::Zero(), du = Pose2::Zero();
    dx(i) = h;
    du(i) = h;
    Eigen::Vector3d ca = (compose(x + dx, u) - compose(x - dx, u)) / (2 * h);
    Eigen::Vector3d cb = (compose(x, u + du) - compose(x, u - du)) / (2 * h);
    ca.z() = normalizeAngle(ca.z() * 2 * h) / (2 * h);
    cb.z() = normalizeAngle(cb.z() * 2 * h) / (2 * h);
    EXPECT_LT((A.col(i) - ca).cwiseAbs().maxCoeff(), 1e-6) << i;
    EXPECT_LT((B.col(i) - cb).cwiseAbs().maxCoeff(), 1e-6) << i;
  }
}

TEST(OdometryNoise, StepCovarianceIsRecoveredFromDeadReckoning) {
  // A robot dead-reckons steps with known noise, its driver propagating the absolute covariance
  // (angles near +-pi included); each step's covariance comes back.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> step(-0.3, 0.6), turn(-0.5, 0.5);
  Pose2 x(2.0, 1.0, 3.0);
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Identity() * 1e-4;
  for (int k = 0; k < 50; ++k) {
    const Pose2 u(step(rng), 0.2 * step(rng), turn(rng));
    Eigen::Matrix3d L = Eigen::Matrix3d::Random() * 0.05;
    const Eigen::Matrix3d sigma_u = L * L.transpose() + Eigen::Matrix3d::Identity() * 1e-4;
    Eigen::Matrix3d A, B;
    compositionJacobians(x, u, A, B);
    const Pose2 next = compose(x, u);
    const Eigen::Matrix3d sigma_next = A * sigma * A.transpose() + B * sigma_u * B.transpose();
    const auto recovered = stepCovarianceFromAbsolute(x, sigma, next, sigma_next);
    ASSERT_TRUE(recovered.has_value()) << k;
    EXPECT_LT((*recovered - sigma_u).cwiseAbs().maxCoeff(), 1e-9) << k;
    x = next;
    sigma = sigma_next;
  }
}

TEST(OdometryNoise, AConstantCovarianceIsNotAStepsCovariance) {
  const Eigen::Matrix3d constant = Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal();
  EXPECT_FALSE(stepCovarianceFromAbsolute(Pose2(0, 0, 0), constant, Pose2(0.5, 0, 0.1), constant));
  EXPECT_FALSE(stepCovarianceFromAbsolute(Pose2(0, 0, 0), Eigen::Matrix3d::Zero(),
                                          Pose2(0.5, 0, 0.1),
                                          Eigen::Matrix3d::Constant(std::nan(""))));
}

TEST(OdometryNoise, MotionModelScalesWithTravelAndTurn) {
  MotionNoise noise;
  noise.stddev = Eigen::Vector3d(0.1, 0.05, 0.02);
  noise.min_travel_m = 0.2;
  noise.min_rotation_rad = 0.1;
  const Eigen::Matrix3d two_metres = stepCovarianceFromMotion(Pose2(2.0, 0.0, 0.0), noise);
  EXPECT_NEAR(std::sqrt(two_metres(0, 0)), 0.2, 1e-12);
  EXPECT_NEAR(std::sqrt(two_metres(1, 1)), 0.1, 1e-12);
  EXPECT_NEAR(std::sqrt(two_metres(2, 2)), 0.02 * (0.1 + 2.0), 1e-12);
  // In place: the minima keep it definite; a turn across +-pi counts as the short way round.
  const Eigen::Matrix3d turn = stepCovarianceFromMotion(Pose2(0.0, 0.0, 2 * M_PI - 0.3), noise);
  EXPECT_NEAR(std::sqrt(turn(0, 0)), 0.1 * 0.2, 1e-12);
  EXPECT_NEAR(std::sqrt(turn(2, 2)), 0.02 * (0.3 + 0.2), 1e-12);
}

}  // namespace
}  // namespace rrr_graphslam::core
