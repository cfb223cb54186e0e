#pragma once
// Sparse symmetric positive-definite solves through CHOLMOD (via Eigen's CholmodSupport).
// The fill-reducing ordering (symbolic analysis) is computed by analyze() once per sparsity
// pattern; factorize() only redoes the numeric factorization, so Gauss-Newton iterations and
// re-optimizations that keep the pattern pay for the ordering once.
//
// CHOLMOD picks supernodal or simplicial Cholesky per pattern (its flops/nnz(L) rule): City10000
// factors supernodally, while M3500 and Intel are 25-45% faster simplicial than forced
// supernodal (measured with scripts/bench_optimizer).

#include <memory>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace rrr_graphslam::core {

class SparseSolver {
 public:
  /// Upper triangle of a symmetric matrix, column-major, compressed.
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  SparseSolver();
  ~SparseSolver();
  SparseSolver(SparseSolver&&) noexcept;
  SparseSolver& operator=(SparseSolver&&) noexcept;

  /// Symbolic analysis (fill-reducing ordering) of the pattern of `upper`.
  void analyze(const Matrix& upper);
  /// Numeric factorization with the last analysis; false if the matrix is not positive definite.
  bool factorize(const Matrix& upper);
  /// Solves A x = rhs with the last successful factorization.
  Eigen::VectorXd solve(const Eigen::VectorXd& rhs) const;
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs) const;

  /// Number of symbolic analyses so far (tests check that the ordering is reused).
  int analysisCount() const { return analysis_count_; }

 private:
  struct Cholmod;
  std::unique_ptr<Cholmod> cholmod_;
  int analysis_count_ = 0;
};

}  // namespace rrr_graphslam::core
