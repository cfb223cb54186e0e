#pragma once
// The inverse of a dense symmetric positive-definite matrix through LAPACK (dpotrf, dpotri), for
// the few places that need a whole dense covariance: the Chow-Liu tree over a Markov blanket of
// hundreds to a thousand nodes. LAPACK's blocked routines run on the BLAS of the machine
// (OpenBLAS, with kernels chosen for the processor when it is loaded), where Eigen's own LLT and
// solve against the identity run on the instructions the product is compiled for and do about
// 2.3 times the flops (7/3 n^3 against n^3): a 3534 x 3534 inverse (a blanket of 1178 nodes) took
// 11 s with Eigen, 1.3 s with LAPACK on OpenBLAS's Haswell kernel (3.0 s on its generic one).

#include <optional>

#include <Eigen/Core>

namespace rrr_graphslam::core {

/// A^-1 (both triangles), or nullopt when A is not positive definite (Cholesky fails). Reads the
/// lower triangle of A only; A must be square and finite (the caller checks: LAPACK may let a
/// NaN through).
std::optional<Eigen::MatrixXd> spdInverse(const Eigen::MatrixXd& a);

}  // namespace rrr_graphslam::core
