#pragma once
// Kullback-Leibler divergence between Gaussians, to say how much a replacement of a marginal
// (chow_liu.h) loses: the target is KL(exact || Chow-Liu tree) <= 0.1 KL(exact || delete).
//
// What is compared (replacementKl): the whole graph's linearized distribution with the exact
// marginal, p0, against the same graph with the replacement in its place, p1. The rest of the
// graph is the same factor r(x) in both, so p0 and p1 share the conditional of every other node
// given the blanket, and by the chain rule KL(p0 || p1) is the KL of their blanket marginals:
// finite for `delete` too (the rest of the graph still holds the blanket), and O(|B|^3) given
// p0's covariance over the blanket, which the optimizer already has (Optimizer::covariance).
// p1 = p0 exp(-1/2 dx^T D dx - d^T dx), with D and d the replacement's information and gradient
// less the marginal's, so with Sigma0 = F F^T and S = I + F^T D F:
//   KL(p0 || p1) = 1/2 [tr(S) - k - ln det S + u^T S^-1 u],  u = F^T d.
//
// Gauge: the marginal and every replacement are relative (a rigid motion of the blanket is in
// the null space of D, and d is orthogonal to it), so tr(S), det S and u^T S^-1 u are the same
// for any gauge fixing of Sigma0: the graph's covariance with one node held, be it the
// optimizer's fixed node (wherever it is) or a blanket node (zero rows and columns for it). KL is
// thus that of the gauge-free distributions. (A covariance conditioned on a blanket node on top
// of the optimizer's fixed node is not a gauge fixing: it drops real uncertainty.)

#include <Eigen/Core>

#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/marginalization.h"

namespace rrr_graphslam::core {

/// KL(N0 || N1) for Gaussians over the same k variables in information form (Lambda = Sigma^-1):
///   1/2 [tr(Lambda1 Sigma0) - k + (mean1 - mean0)^T Lambda1 (mean1 - mean0)
///        + ln det Lambda0 - ln det Lambda1]   (nats).
/// Throws std::invalid_argument for mismatched sizes or an information matrix that is not
/// positive definite (anchor a node first if it carries a gauge).
double gaussianKl(const Eigen::VectorXd& mean0, const Eigen::MatrixXd& information0,
                  const Eigen::VectorXd& mean1, const Eigen::MatrixXd& information1);

/// p0, given by its covariance over the variables that changes touch, factored once
/// (Sigma0 = F F^T, pivoted LDLT) for several changes compared against it, e.g. a trim's tree
/// and deletion. The free functions below build one per call.
class KlReference {
 public:
  /// Throws std::invalid_argument for a covariance that is not square or not finite.
  explicit KlReference(const Eigen::MatrixXd& covariance0);
  /// As the free klOfFactorChange.
  double klOfFactorChange(const Eigen::MatrixXd& information_change,
                          const Eigen::VectorXd& gradient_change) const;
  /// As the free replacementKl.
  double replacementKl(const Marginal& marginal, const QuadraticModel& replacement) const;

 private:
  Eigen::MatrixXd square_root_;  ///< F
};

/// KL(p0 || p1) for p1 = p0 exp(-1/2 dx^T information_change dx - gradient_change^T dx), with
/// p0's covariance over the variables the change touches (positive semi-definite; rows and
/// columns of anchored variables zero) and p0's mean at dx = 0. +infinity when p1 keeps less
/// than 1e-12 of p0's information in some direction (improper, or as good as: rounding cannot
/// tell smaller ratios from zero), e.g. when deleting constraints disconnects the graph.
double klOfFactorChange(const Eigen::MatrixXd& covariance0,
                        const Eigen::MatrixXd& information_change,
                        const Eigen::VectorXd& gradient_change);

/// KL(graph with `marginal` || graph with `replacement` in its place), see above.
/// `blanket_covariance` is the current graph's joint covariance of marginal.blanket (in its
/// order, any gauge fixing, e.g. Optimizer::covariance); the linearization point must be the
/// current graph's minimum (optimize before trimming), which makes it p0's mean.
double replacementKl(const Eigen::MatrixXd& blanket_covariance, const Marginal& marginal,
                     const QuadraticModel& replacement);

}  // namespace rrr_graphslam::core
