#include "rrr_graphslam/core/sparse_solver.h"

#include <omp.h>

#include <Eigen/CholmodSupport>

namespace rrr_graphslam::core {
namespace {

// Debian's CHOLMOD is built with CHOLMOD_OMP_NUM_THREADS = 4, a num_threads clause that no
// environment variable overrides. On a 2-core robot computer its thread wake-ups cost more than
// the parallel loops save (City10000: 0.51 s -> 0.27 s per full solve), so
// CHOLMOD's parallel regions run inactive (one thread) while we call it.
class ScopedSingleThreadedOpenMp {
 public:
  ScopedSingleThreadedOpenMp() : saved_levels_(omp_get_max_active_levels()) {
    omp_set_max_active_levels(0);
  }
  ~ScopedSingleThreadedOpenMp() { omp_set_max_active_levels(saved_levels_); }
  ScopedSingleThreadedOpenMp(const ScopedSingleThreadedOpenMp&) = delete;
  ScopedSingleThreadedOpenMp& operator=(const ScopedSingleThreadedOpenMp&) = delete;

 private:
  int saved_levels_;
};

}  // namespace

struct SparseSolver::Cholmod {
  Eigen::CholmodDecomposition<Matrix, Eigen::Upper> llt;  // CHOLMOD_AUTO: supernodal or simplicial
};

SparseSolver::SparseSolver() : cholmod_(std::make_unique<Cholmod>()) {}
SparseSolver::~SparseSolver() = default;
SparseSolver::SparseSolver(SparseSolver&&) noexcept = default;
SparseSolver& SparseSolver::operator=(SparseSolver&&) noexcept = default;

void SparseSolver::analyze(const Matrix& upper) {
  const ScopedSingleThreadedOpenMp single;
  cholmod_->llt.analyzePattern(upper);
  ++analysis_count_;
}

bool SparseSolver::factorize(const Matrix& upper) {
  const ScopedSingleThreadedOpenMp single;
  cholmod_->llt.factorize(upper);
  return cholmod_->llt.info() == Eigen::Success;
}

Eigen::VectorXd SparseSolver::solve(const Eigen::VectorXd& rhs) const {
  return cholmod_->llt.solve(rhs);
}

Eigen::MatrixXd SparseSolver::solve(const Eigen::MatrixXd& rhs) const {
  return cholmod_->llt.solve(rhs);
}

}  // namespace rrr_graphslam::core
