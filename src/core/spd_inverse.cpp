#include "rrr_graphslam/core/spd_inverse.h"

#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

extern "C" {
// LAPACK (Fortran calling convention, 32-bit integers as Debian's liblapack3 and OpenBLAS build
// it; gfortran's hidden length of the character argument last).
void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info,
             std::size_t uplo_length);
void dpotri_(const char* uplo, const int* n, double* a, const int* lda, int* info,
             std::size_t uplo_length);
}

namespace rrr_graphslam::core {

std::optional<Eigen::MatrixXd> spdInverse(const Eigen::MatrixXd& a) {
  if (a.rows() != a.cols()) {
    throw std::invalid_argument("spdInverse: the matrix is " + std::to_string(a.rows()) + "x" +
                                std::to_string(a.cols()) + ", not square");
  }
  if (a.rows() > std::numeric_limits<int>::max()) {
    throw std::invalid_argument("spdInverse: too large for LAPACK's 32-bit sizes");
  }
  if (a.rows() == 0) return Eigen::MatrixXd(0, 0);
  Eigen::MatrixXd inverse = a;  // column-major, as LAPACK reads it
  const int n = static_cast<int>(a.rows());
  int info = 0;
  dpotrf_("L", &n, inverse.data(), &n, &info, 1);
  if (info < 0)
    throw std::logic_error("spdInverse: dpotrf refused argument " + std::to_string(-info));
  if (info > 0) return std::nullopt;  // not positive definite
  dpotri_("L", &n, inverse.data(), &n, &info, 1);
  if (info < 0)
    throw std::logic_error("spdInverse: dpotri refused argument " + std::to_string(-info));
  if (info > 0) return std::nullopt;
  return Eigen::MatrixXd(inverse.selfadjointView<Eigen::Lower>());
}

}  // namespace rrr_graphslam::core
