#include "rrr_graphslam/core/largest_eigenvalue.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace rrr_graphslam::core {

double largestEigenvalue(const Eigen::MatrixXd& m) {
  const Eigen::Index k = m.rows();
  if (k == 0 || m.cols() != k) {
    throw std::invalid_argument("largestEigenvalue: the matrix is " + std::to_string(k) + "x" +
                                std::to_string(m.cols()) + ", not square and non-empty");
  }
  if (!m.allFinite()) throw std::invalid_argument("largestEigenvalue: the matrix is not finite");
  auto fullSolver = [&] {
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m, Eigen::EigenvaluesOnly)
        .eigenvalues()
        .maxCoeff();
  };
  constexpr Eigen::Index kSmall = 64;
  constexpr Eigen::Index kMaxSteps = 120;
  if (k <= kSmall) return fullSolver();
  const Eigen::Index max_steps = std::min(k, kMaxSteps);
  Eigen::MatrixXd q(k, max_steps + 1);  // the Lanczos vectors
  Eigen::VectorXd alpha(max_steps), beta(max_steps);
  for (Eigen::Index i = 0; i < k; ++i) q(i, 0) = 1.0 + 0.5 * std::sin(1.0 + i);  // generic
  q.col(0).normalize();
  const double scale = m.cwiseAbs().maxCoeff();
  for (Eigen::Index j = 0; j < max_steps; ++j) {
    Eigen::VectorXd w = m * q.col(j);
    alpha(j) = q.col(j).dot(w);
    for (int twice = 0; twice < 2; ++twice) {
      w -= q.leftCols(j + 1) * (q.leftCols(j + 1).transpose() * w);
    }
    beta(j) = w.norm();
    const bool invariant = beta(j) <= 1e-14 * scale;  // the Ritz values are eigenvalues
    if (invariant || (j + 1) % 10 == 0 || j + 1 == max_steps) {
      const Eigen::Index n = j + 1;
      Eigen::MatrixXd t = Eigen::MatrixXd::Zero(n, n);
      t.diagonal() = alpha.head(n);
      if (n > 1) {
        t.diagonal(1) = beta.head(n - 1);
        t.diagonal(-1) = beta.head(n - 1);
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ritz(t);
      const double theta = ritz.eigenvalues()(n - 1);
      const double residual = beta(j) * std::abs(ritz.eigenvectors()(n - 1, n - 1));
      if (invariant) return theta;
      if (residual <= 1e-12 * std::abs(theta)) return theta + residual;
    }
    q.col(j + 1) = w / beta(j);
  }
  return fullSolver();
}

}  // namespace rrr_graphslam::core
