#include "rrr_graphslam/core/sparse_solver.h"

#include <Eigen/CholmodSupport>

namespace rrr_graphslam::core {

struct SparseSolver::Cholmod {
  Eigen::CholmodSupernodalLLT<Matrix, Eigen::Upper> llt;
};

SparseSolver::SparseSolver() : cholmod_(std::make_unique<Cholmod>()) {}
SparseSolver::~SparseSolver() = default;
SparseSolver::SparseSolver(SparseSolver&&) noexcept = default;
SparseSolver& SparseSolver::operator=(SparseSolver&&) noexcept = default;

void SparseSolver::analyze(const Matrix& upper) {
  cholmod_->llt.analyzePattern(upper);
  ++analysis_count_;
}

bool SparseSolver::factorize(const Matrix& upper) {
  cholmod_->llt.factorize(upper);
  return cholmod_->llt.info() == Eigen::Success;
}

Eigen::VectorXd SparseSolver::solve(const Eigen::VectorXd& rhs) const {
  return cholmod_->llt.solve(rhs);
}

}  // namespace rrr_graphslam::core
