// Analytic SE(2) Jacobians against central differences, including angles near +-pi.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/LU>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {
namespace {

Eigen::Matrix3d numericJacobian(const Pose2& xi, const Pose2& xj, const Pose2& z, bool wrt_from) {
  constexpr double kStep = 1e-6;
  Eigen::Matrix3d J;
  for (int k = 0; k < 3; ++k) {
    Pose2 plus_i = xi, minus_i = xi, plus_j = xj, minus_j = xj;
    (wrt_from ? plus_i : plus_j)(k) += kStep;
    (wrt_from ? minus_i : minus_j)(k) -= kStep;
    Eigen::Vector3d d = edgeError(plus_i, plus_j, z) - edgeError(minus_i, minus_j, z);
    d.z() = normalizeAngle(d.z());
    J.col(k) = d / (2.0 * kStep);
  }
  return J;
}

TEST(Se2, NormalizeAngleIsHalfOpen) {
  EXPECT_DOUBLE_EQ(normalizeAngle(M_PI), M_PI);
  EXPECT_DOUBLE_EQ(normalizeAngle(-M_PI), M_PI);
  EXPECT_NEAR(normalizeAngle(3 * M_PI + 0.1), -M_PI + 0.1, 1e-12);
  EXPECT_NEAR(normalizeAngle(-7.0), -7.0 + 2 * M_PI, 1e-12);
  EXPECT_DOUBLE_EQ(normalizeAngle(1e-12), 1e-12);
}

TEST(Se2, ComposeInverseBetween) {
  const Pose2 a(1.0, -2.0, 0.7), b(0.3, 0.4, -2.9);
  const Pose2 identity = compose(a, inverse(a));
  EXPECT_NEAR(identity.norm(), 0.0, 1e-12);
  const Pose2 ab = compose(a, b);
  EXPECT_NEAR((between(a, ab) - b).norm(), 0.0, 1e-12);
}

TEST(Se2, ErrorIsZeroForExactMeasurement) {
  const Pose2 xi(2.0, 1.0, 3.1), xj(-1.0, 4.0, -3.1);
  const Eigen::Vector3d e = edgeError(xi, xj, between(xi, xj));
  EXPECT_NEAR(e.norm(), 0.0, 1e-12);
}

TEST(Se2, JacobiansMatchNumericalDifferentiation) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> position(-10.0, 10.0);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::uniform_real_distribution<double> tiny(-1e-7, 1e-7);
  const double special_angles[] = {M_PI - 1e-9, -M_PI + 1e-9, M_PI, 0.0, 1e-10, -1e-10};
  for (int trial = 0; trial < 500; ++trial) {
    Pose2 xi(position(rng), position(rng), angle(rng));
    Pose2 xj(position(rng), position(rng), angle(rng));
    Pose2 z(position(rng) * 0.2, position(rng) * 0.2, angle(rng));
    if (trial < 6) {
      // Angles at the wrap-around and tiny angles, at the ends and in the measurement.
      xi.z() = special_angles[trial];
      xj.z() = special_angles[5 - trial];
      z.z() = special_angles[(trial + 2) % 6];
    } else if (trial < 12) {
      z = between(xi, xj) + Pose2(tiny(rng), tiny(rng), tiny(rng));  // near-zero error
    }
    const EdgeLinearization lin = linearizeEdge(xi, xj, z);
    EXPECT_NEAR((lin.error - edgeError(xi, xj, z)).norm(), 0.0, 1e-12);
    EXPECT_LT((lin.J_from - numericJacobian(xi, xj, z, true)).norm(), 1e-5) << "trial " << trial;
    EXPECT_LT((lin.J_to - numericJacobian(xi, xj, z, false)).norm(), 1e-5) << "trial " << trial;
  }
}

// Reversing a measurement with noise on the right, z * n: z^-1 gets the noise m(n) with
// (z * n)^-1 = z^-1 * m(n); its covariance is J C J^T for J = dm/dn at 0 (central differences).
TEST(Se2, CovarianceOfInverseMatchesNumericalPropagation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-3.0, 3.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose2 z(uniform(rng), uniform(rng), normalizeAngle(uniform(rng)));
    const Eigen::Matrix3d A = Eigen::Matrix3d::Random() + 2.0 * Eigen::Matrix3d::Identity();
    const Eigen::Matrix3d C = A * A.transpose();  // a covariance with correlations
    constexpr double kStep = 1e-6;
    Eigen::Matrix3d J;
    for (int k = 0; k < 3; ++k) {
      const Pose2 n = kStep * Eigen::Vector3d::Unit(k);
      Eigen::Vector3d d = between(inverse(z), inverse(compose(z, n))) -
                          between(inverse(z), inverse(compose(z, -n)));
      d.z() = normalizeAngle(d.z());
      J.col(k) = d / (2.0 * kStep);
    }
    const Eigen::Matrix3d expected = J * C * J.transpose();
    EXPECT_LT((covarianceOfInverse(z, C) - expected).norm(), 1e-6 * expected.norm());
    EXPECT_LT((informationOfInverse(z, C.inverse()) - expected.inverse()).norm(),
              1e-6 * expected.inverse().norm());
  }
}

}  // namespace
}  // namespace rrr_graphslam::core
