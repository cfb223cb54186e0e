#include "rrr_graphslam/core/gaussian_kl.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace rrr_graphslam::core {
namespace {

// Generalized eigenvalues of p1's information against p0's below this are taken as zero.
constexpr double kLostInformation = 1e-12;

std::string sizes(Eigen::Index a, Eigen::Index b) {
  return std::to_string(a) + " against " + std::to_string(b);
}

}  // namespace

double gaussianKl(const Eigen::VectorXd& mean0, const Eigen::MatrixXd& information0,
                  const Eigen::VectorXd& mean1, const Eigen::MatrixXd& information1) {
  const Eigen::Index k = mean0.size();
  if (mean1.size() != k || information0.rows() != k || information0.cols() != k ||
      information1.rows() != k || information1.cols() != k) {
    throw std::invalid_argument("gaussianKl: sizes disagree (means " +
                                sizes(mean0.size(), mean1.size()) + ", information " +
                                sizes(information0.rows(), information1.rows()) + ")");
  }
  const Eigen::LLT<Eigen::MatrixXd> llt0(information0), llt1(information1);
  if (llt0.info() != Eigen::Success || llt1.info() != Eigen::Success) {
    throw std::invalid_argument(std::string("gaussianKl: information") +
                                (llt0.info() != Eigen::Success ? "0" : "1") +
                                " is not positive definite");
  }
  auto logDet = [](const Eigen::LLT<Eigen::MatrixXd>& llt) {
    return 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  };
  const Eigen::MatrixXd sigma0 = llt0.solve(Eigen::MatrixXd::Identity(k, k));
  const Eigen::VectorXd shift = mean1 - mean0;
  return 0.5 * ((information1 * sigma0).trace() - static_cast<double>(k) +
                shift.dot(information1 * shift) + logDet(llt0) - logDet(llt1));
}

double klOfFactorChange(const Eigen::MatrixXd& covariance0,
                        const Eigen::MatrixXd& information_change,
                        const Eigen::VectorXd& gradient_change) {
  const Eigen::Index k = covariance0.rows();
  if (covariance0.cols() != k || information_change.rows() != k || information_change.cols() != k ||
      gradient_change.size() != k) {
    throw std::invalid_argument(
        "klOfFactorChange: sizes disagree (covariance " + sizes(k, covariance0.cols()) +
        ", information change " + sizes(information_change.rows(), information_change.cols()) +
        ", gradient change " + std::to_string(gradient_change.size()) + ")");
  }
  if (!covariance0.allFinite() || !information_change.allFinite() || !gradient_change.allFinite()) {
    throw std::invalid_argument("klOfFactorChange: an input is not finite");
  }
  // Sigma0 = F F^T from its eigen decomposition (positive semi-definite: clamp rounding).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> sigma(
      0.5 * (covariance0 + covariance0.transpose()));
  const Eigen::MatrixXd F =
      sigma.eigenvectors() * sigma.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  // S = I + F^T D F, whose eigenvalues are p1's information relative to p0's, direction by
  // direction; KL = 1/2 sum (lambda - 1 - ln lambda + (q^T u)^2 / lambda).
  const Eigen::MatrixXd D = 0.5 * (information_change + information_change.transpose());
  const Eigen::MatrixXd S = Eigen::MatrixXd::Identity(k, k) + F.transpose() * D * F;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> s(S);
  const Eigen::VectorXd& lambda = s.eigenvalues();
  if (k > 0 && lambda.minCoeff() < kLostInformation) return std::numeric_limits<double>::infinity();
  const Eigen::VectorXd u = s.eigenvectors().transpose() * (F.transpose() * gradient_change);
  double kl = 0.0;
  for (Eigen::Index i = 0; i < k; ++i) {
    kl += lambda(i) - 1.0 - std::log(lambda(i)) + u(i) * u(i) / lambda(i);
  }
  return 0.5 * kl;
}

double replacementKl(const Eigen::MatrixXd& blanket_covariance, const Marginal& marginal,
                     const QuadraticModel& replacement) {
  const Eigen::Index k = marginal.information.rows();
  if (replacement.information.rows() != k || replacement.information.cols() != k ||
      replacement.gradient.size() != k || marginal.gradient.size() != k) {
    throw std::invalid_argument("replacementKl: the replacement's sizes (" +
                                sizes(replacement.information.rows(), replacement.gradient.size()) +
                                ") differ from the marginal's (" +
                                sizes(k, marginal.gradient.size()) + ")");
  }
  return klOfFactorChange(blanket_covariance, replacement.information - marginal.information,
                          replacement.gradient - marginal.gradient);
}

}  // namespace rrr_graphslam::core
