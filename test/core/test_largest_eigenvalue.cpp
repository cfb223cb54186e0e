// largestEigenvalue (Lanczos beyond 64 rows) against Eigen's full solver: random positive
// semi-definite matrices, a nearly double top eigenvalue, a start vector almost orthogonal to the
// top eigenvector, an indefinite matrix; never below the full solver's value by more than
// rounding, never above by more than 1e-12 of it.

#include "rrr_graphslam/core/largest_eigenvalue.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace rrr_graphslam::core {
namespace {

double slowLargest(const Eigen::MatrixXd& m) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues().maxCoeff();
}

Eigen::MatrixXd randomOrthogonal(Eigen::Index k, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd a(k, k);
  for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] = n(rng);
  return Eigen::HouseholderQR<Eigen::MatrixXd>(a).householderQ();
}

// V diag(spectrum) V^T with a random orthogonal V.
Eigen::MatrixXd withSpectrum(const Eigen::VectorXd& spectrum, std::mt19937& rng) {
  const Eigen::MatrixXd v = randomOrthogonal(spectrum.size(), rng);
  const Eigen::MatrixXd m = v * spectrum.asDiagonal() * v.transpose();
  return 0.5 * (m + m.transpose());
}

void expectAgrees(const Eigen::MatrixXd& m, const char* what) {
  const double slow = slowLargest(m);
  const double fast = largestEigenvalue(m);
  const double tolerance = 1e-12 * std::abs(slow) + 1e-13 * m.cwiseAbs().maxCoeff();
  EXPECT_GE(fast, slow - tolerance) << what << " k " << m.rows();
  EXPECT_LE(fast, slow + 2e-12 * std::abs(slow) + tolerance) << what << " k " << m.rows();
}

TEST(LargestEigenvalue, AgreesWithTheFullSolver) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Eigen::Index k : {1, 10, 64, 65, 100, 300}) {
    // Positive semi-definite with trace k and a spread spectrum, as the whitened covariances of
    // chow_liu.cpp: a Wishart-like sample.
    Eigen::MatrixXd a(k, k / 2 + 1);
    std::normal_distribution<double> n(0.0, 1.0);
    for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] = n(rng);
    expectAgrees(a * a.transpose(), "wishart");

    Eigen::VectorXd spectrum(k);
    for (Eigen::Index i = 0; i < k; ++i) spectrum(i) = u(rng);
    spectrum(0) = 1.5;
    if (k > 1) spectrum(1) = 1.5 - 1e-9;  // a nearly double top eigenvalue
    expectAgrees(withSpectrum(spectrum, rng), "double top");

    for (Eigen::Index i = 0; i < k; ++i) spectrum(i) = 2.0 * u(rng) - 1.0;  // indefinite
    expectAgrees(withSpectrum(spectrum, rng), "indefinite");
  }
}

// The top eigenvector almost orthogonal to Lanczos's fixed start vector: its component there is
// 1e-10, and the largest eigenvalue is still found, not the second one.
TEST(LargestEigenvalue, FindsATopEigenvectorTheStartHardlySees) {
  std::mt19937 rng(5);
  const Eigen::Index k = 200;
  Eigen::VectorXd start(k);
  for (Eigen::Index i = 0; i < k; ++i) start(i) = 1.0 + 0.5 * std::sin(1.0 + i);
  start.normalize();
  Eigen::MatrixXd basis = randomOrthogonal(k, rng);
  // Replace the first basis vector by one almost orthogonal to the start, then re-orthogonalize.
  Eigen::VectorXd top = basis.col(1) - basis.col(1).dot(start) * start + 1e-10 * start;
  basis.col(0) = top.normalized();
  const Eigen::MatrixXd v = Eigen::HouseholderQR<Eigen::MatrixXd>(basis).householderQ();
  Eigen::VectorXd spectrum = Eigen::VectorXd::LinSpaced(k, 0.0, 1.0);
  spectrum(0) = 3.0;
  const Eigen::MatrixXd m = v * spectrum.asDiagonal() * v.transpose();
  const Eigen::MatrixXd sym = 0.5 * (m + m.transpose());
  EXPECT_NEAR(largestEigenvalue(sym), 3.0, 1e-9);
}

TEST(LargestEigenvalue, BadMatricesThrow) {
  EXPECT_THROW(largestEigenvalue(Eigen::MatrixXd(0, 0)), std::invalid_argument);
  EXPECT_THROW(largestEigenvalue(Eigen::MatrixXd::Identity(3, 2)), std::invalid_argument);
  Eigen::MatrixXd nan = Eigen::MatrixXd::Identity(70, 70);
  nan(3, 4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(largestEigenvalue(nan), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::core
