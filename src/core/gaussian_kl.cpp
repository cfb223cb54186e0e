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

KlReference::KlReference(const Eigen::MatrixXd& covariance0) {
  if (covariance0.cols() != covariance0.rows()) {
    throw std::invalid_argument("KlReference: the covariance is " +
                                sizes(covariance0.rows(), covariance0.cols()) + ", not square");
  }
  if (!covariance0.allFinite()) {
    throw std::invalid_argument("KlReference: the covariance is not finite");
  }
  // Sigma0 = P^T L D L^T P (symmetric pivoting copes with the zero rows of anchored variables),
  // F = P^T L D^1/2 (positive semi-definite: rounding below zero clamped).
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(0.5 * (covariance0 + covariance0.transpose()));
  const Eigen::MatrixXd L = ldlt.matrixL();
  square_root_ = ldlt.transpositionsP().transpose() *
                 (L * ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().asDiagonal());
}

double KlReference::klOfFactorChange(const Eigen::MatrixXd& information_change,
                                     const Eigen::VectorXd& gradient_change) const {
  const Eigen::Index k = square_root_.rows();
  if (information_change.rows() != k || information_change.cols() != k ||
      gradient_change.size() != k) {
    throw std::invalid_argument(
        "klOfFactorChange: sizes disagree (covariance " + sizes(k, k) + ", information change " +
        sizes(information_change.rows(), information_change.cols()) + ", gradient change " +
        std::to_string(gradient_change.size()) + ")");
  }
  if (!information_change.allFinite() || !gradient_change.allFinite()) {
    throw std::invalid_argument("klOfFactorChange: an input is not finite");
  }
  if (k == 0) return 0.0;
  // S = I + F^T D F, whose eigenvalues are p1's information relative to p0's, direction by
  // direction: KL = 1/2 (sum (lambda - 1 - ln lambda) + u^T S^-1 u).
  const Eigen::MatrixXd D = 0.5 * (information_change + information_change.transpose());
  const Eigen::MatrixXd S =
      Eigen::MatrixXd::Identity(k, k) + square_root_.transpose() * (D * square_root_);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> s(S, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd& lambda = s.eigenvalues();
  if (lambda.minCoeff() < kLostInformation) return std::numeric_limits<double>::infinity();
  double kl = 0.0;
  for (Eigen::Index i = 0; i < k; ++i) kl += lambda(i) - 1.0 - std::log(lambda(i));
  const Eigen::VectorXd u = square_root_.transpose() * gradient_change;
  if (!u.isZero(0.0)) kl += u.dot(Eigen::LDLT<Eigen::MatrixXd>(S).solve(u));
  return 0.5 * kl;
}

double KlReference::replacementKl(const Marginal& marginal,
                                  const QuadraticModel& replacement) const {
  const Eigen::Index k = marginal.information.rows();
  if (replacement.information.rows() != k || replacement.information.cols() != k ||
      replacement.gradient.size() != k || marginal.gradient.size() != k) {
    throw std::invalid_argument("replacementKl: the replacement's sizes (" +
                                sizes(replacement.information.rows(), replacement.gradient.size()) +
                                ") differ from the marginal's (" +
                                sizes(k, marginal.gradient.size()) + ")");
  }
  return klOfFactorChange(replacement.information - marginal.information,
                          replacement.gradient - marginal.gradient);
}

double klOfFactorChange(const Eigen::MatrixXd& covariance0,
                        const Eigen::MatrixXd& information_change,
                        const Eigen::VectorXd& gradient_change) {
  return KlReference(covariance0).klOfFactorChange(information_change, gradient_change);
}

double replacementKl(const Eigen::MatrixXd& blanket_covariance, const Marginal& marginal,
                     const QuadraticModel& replacement) {
  return KlReference(blanket_covariance).replacementKl(marginal, replacement);
}

}  // namespace rrr_graphslam::core
