#pragma once
// Chi-square quantiles for the consistency tests (Boost.Math), cached per (alpha, dof) because
// RRR asks for the same few thousand values over and over.

namespace rrr_graphslam::core {

/// The alpha-quantile of the chi-square distribution with `dof` degrees of freedom, e.g.
/// chi2Quantile(0.95, 3) = 7.8147. alpha in (0, 1), dof >= 1; throws std::invalid_argument else.
double chi2Quantile(double alpha, int dof);

}  // namespace rrr_graphslam::core
