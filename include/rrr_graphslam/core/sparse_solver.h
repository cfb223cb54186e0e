#pragma once
// Sparse symmetric positive-definite solves through CHOLMOD (via Eigen's CholmodSupport).
// The symbolic analysis is done by analyze() once per sparsity pattern; factorize() only redoes
// the numeric factorization, so Gauss-Newton iterations and re-optimizations that keep the
// pattern pay for it once. The optimizer orders the 3x3 blocks itself (blockOrdering(), AMD or
// METIS on the block graph) and assembles H already permuted, so CHOLMOD neither orders the 9x
// larger scalar pattern nor copies and transposes H into its ordering at every factorization (M3500
// 55 -> 41 ms, Intel 5.5 -> 4.8 ms in scripts/bench_optimizer). update() folds a few
// constraints switched on or off into the factor by rank updates (cholmod_updown).
//
// CHOLMOD picks supernodal or simplicial Cholesky per pattern (its flops/nnz(L) rule): City10000
// factors supernodally, while M3500 and Intel are 25-45% faster simplicial than forced
// supernodal (measured with scripts/bench_optimizer). A factor meant for updates can be kept
// simplicial (Kind::kSimplicial): an update converts a supernodal one first, and the next
// factorization analyzes the pattern again.

#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace rrr_graphslam::core {

/// A fill-reducing order of blocks: order[k] is the block to place k-th.
struct BlockOrdering {
  /// kAuto: AMD, and METIS's nested dissection too where AMD's factor fills in badly
  /// (CHOLMOD's own rule for its default strategy, on the block graph); the order with fewer
  /// flops wins. The others force one method (tests, measurements).
  enum class Method { kAuto, kAmd, kNestedDissection };

  std::vector<int> order;
  bool nested_dissection = false;  ///< METIS's order, not AMD's
  double flops = 0;                ///< of the block factor in this order (CHOLMOD's count)
};

/// A fill-reducing order of `num_blocks` blocks coupled by `pairs`, through CHOLMOD. Ordering
/// the 3x3 blocks instead of the scalars is the same ordering problem on a graph 9 times smaller.
BlockOrdering blockOrdering(int num_blocks, const std::vector<std::pair<int, int>>& pairs,
                            BlockOrdering::Method method = BlockOrdering::Method::kAuto);

/// The numeric factorizations a solver made, summed: where a pose-graph method's time goes
/// (rrr::StepProfile reads them per step).
struct FactorizationWork {
  int factorizations = 0;
  double seconds = 0.0;
  double flops = 0.0;  ///< CHOLMOD's count for each factorization's pattern, summed
};

class SparseSolver {
 public:
  /// Upper triangle of a symmetric matrix, column-major, compressed.
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  SparseSolver();
  ~SparseSolver();
  SparseSolver(SparseSolver&&) noexcept;
  SparseSolver& operator=(SparseSolver&&) noexcept;

  /// Which Cholesky factor: CHOLMOD's choice per pattern (supernodal when the factor is dense
  /// enough), or always simplicial LDL', the form update() works on.
  enum class Kind { kAuto, kSimplicial };

  /// Symbolic analysis of the pattern of `upper`: CHOLMOD's fill-reducing ordering, or with
  /// `preordered` none (the caller assembled the matrix in a fill-reducing order, see
  /// blockOrdering(); CHOLMOD then factors it without permuting and transposing it each time).
  void analyze(const Matrix& upper, bool preordered = false, Kind kind = Kind::kAuto);
  /// Numeric factorization with the last analysis; false if the matrix is not positive definite.
  bool factorize(const Matrix& upper);
  /// Rank update (add) or downdate (!add) of the current factorization, which then factors
  /// A + C C' (or A - C C') for the A it factored (CHOLMOD's cholmod_updown; a supernodal factor
  /// is converted to simplicial LDL' for it). C has A's rows in their natural order. Returns
  /// false when there is no factorization or CHOLMOD fails (a downdate that loses positive
  /// definiteness); factorize() must then run before the next solve. The next factorize() after
  /// an update starts from the symbolic analysis again (redone if it was supernodal).
  bool update(const Matrix& C, bool add);
  /// Solves A x = rhs with the last successful factorization.
  Eigen::VectorXd solve(const Eigen::VectorXd& rhs) const;
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs) const;
  /// B' A^-1 B (k x k for k columns of B, which has A's rows in their natural order) from the
  /// last successful factorization P A P' = L D L': Y' D^-1 Y with Y = L^-1 P B. A forward solve
  /// of a sparse column fills only the rows on the paths from its entries to the root of the
  /// elimination tree, so Y costs those paths, not full solves: a simplicial factor is walked
  /// column by column, a supernodal one supernode by supernode for all columns at once (its
  /// dense separators near the root are where the paths meet), each supernode for the range of
  /// columns whose paths reach it. The covariance of a linear function of the variables (the
  /// relative poses of loop links: RRR's linearized tests) needs no covariance of the variables
  /// themselves: one column per row of the function, not per variable. Zero without a usable
  /// factorization; std::invalid_argument when B's rows are not A's.
  /// solve(B) then B' times it is the slow, obvious version (test_sparse_solver compares them).
  Eigen::MatrixXd inverseProjection(const Matrix& B) const;
  /// The rows and columns `indices` of A^-1 (marginal covariances): inverseProjection of the
  /// unit columns.
  Eigen::MatrixXd inverseSubmatrix(const std::vector<int>& indices) const;

  /// The order of the matrix of the last analysis (0 before any): the rows inverseProjection's B
  /// must have.
  int dimension() const;
  /// Whether the current factor is supernodal (CHOLMOD's choice for the pattern; an update()
  /// makes it simplicial).
  bool supernodal() const;

  /// Number of symbolic analyses so far (tests check that the ordering is reused).
  int analysisCount() const { return analysis_count_; }
  /// The numeric factorizations so far (factorize(); rank updates are not counted).
  const FactorizationWork& work() const { return work_; }

 private:
  // After an analysis: the flops CHOLMOD counts for a factorization of its pattern.
  void rememberAnalysisFlops();

  struct Cholmod;
  std::unique_ptr<Cholmod> cholmod_;
  int analysis_count_ = 0;
  bool updated_ = false;        // the factor was modified by update()
  bool reanalyze_ = false;      // ... and was supernodal before: analyze again to restore it
  bool factor_usable_ = false;  // a successful factorization (or update) is in place
  double analysis_flops_ = 0.0;
  FactorizationWork work_;
};

}  // namespace rrr_graphslam::core
