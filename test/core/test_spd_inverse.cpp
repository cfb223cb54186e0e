// spdInverse (LAPACK) against Eigen's Cholesky solve of the identity, and its refusals.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <stdexcept>

#include "rrr_graphslam/core/spd_inverse.h"

namespace rrr_graphslam::core {
namespace {

Eigen::MatrixXd randomSpd(Eigen::Index n) {
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, n);
  return b * b.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
}

TEST(SpdInverse, MatchesTheCholeskySolveOfTheIdentity) {
  for (Eigen::Index n : {1, 3, 40, 300}) {  // 300: beyond LAPACK's block size
    const Eigen::MatrixXd a = randomSpd(n);
    const auto inverse = spdInverse(a);
    ASSERT_TRUE(inverse) << n;
    const Eigen::MatrixXd expected = a.llt().solve(Eigen::MatrixXd::Identity(n, n));
    EXPECT_LT((*inverse - expected).norm(), 1e-9 * expected.norm()) << n;
    EXPECT_EQ(*inverse, inverse->transpose()) << "both triangles, exactly symmetric";
  }
}

TEST(SpdInverse, ReadsTheLowerTriangleOnly) {
  const Eigen::MatrixXd a = randomSpd(20);
  Eigen::MatrixXd lower_only = a;
  lower_only.triangularView<Eigen::StrictlyUpper>().setConstant(1e300);
  const auto inverse = spdInverse(lower_only);
  ASSERT_TRUE(inverse);
  EXPECT_LT((*inverse * a - Eigen::MatrixXd::Identity(20, 20)).norm(), 1e-8);
}

TEST(SpdInverse, RefusesWhatIsNotPositiveDefinite) {
  Eigen::MatrixXd singular = randomSpd(10);
  singular.row(4).setZero();
  singular.col(4).setZero();
  EXPECT_FALSE(spdInverse(singular));
  EXPECT_FALSE(spdInverse(-randomSpd(5)));
  EXPECT_THROW(spdInverse(Eigen::MatrixXd::Identity(3, 4)), std::invalid_argument);
  const auto empty = spdInverse(Eigen::MatrixXd(0, 0));
  ASSERT_TRUE(empty);
  EXPECT_EQ(empty->size(), 0);
}

}  // namespace
}  // namespace rrr_graphslam::core
