#pragma once
// The largest eigenvalue of a symmetric matrix, as chow_liu.h's conservative scaling needs it:
// never below the true one by more than rounding, so that a tree scaled by it states nowhere
// more than the marginal.
//
// Up to 64 rows: Eigen's full solver (eigenvalues only). Larger: Lanczos with full
// reorthogonalization from a fixed generic start, whose largest Ritz value theta converges to
// the largest eigenvalue from below in a few dozen products of O(k^2) (the full solver's
// tridiagonalization is O(k^3)); it is accepted when its residual r is at most 1e-12 of it, and
// theta + r returned (an eigenvalue lies within r of theta: the largest, once Lanczos has found
// it). The full solver when that has not happened within 120 steps.

#include <Eigen/Core>

namespace rrr_graphslam::core {

/// The largest eigenvalue of the symmetric matrix `m` (both triangles are read), or at most
/// 1e-12 of it above. Throws std::invalid_argument for an empty, non-square or non-finite matrix.
double largestEigenvalue(const Eigen::MatrixXd& m);

}  // namespace rrr_graphslam::core
