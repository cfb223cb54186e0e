#include "rrr_graphslam/core/sparse_solver.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/CholmodSupport>

#include "rrr_graphslam/core/scoped_single_threaded_openmp.h"

namespace rrr_graphslam::core {

// Debian's CHOLMOD is built with CHOLMOD_OMP_NUM_THREADS = 4, a num_threads clause that no
// environment variable overrides. On a 2-core robot computer its thread wake-ups cost more than
// the parallel loops save (City10000: 0.51 s -> 0.27 s per full solve), so CHOLMOD's parallel
// regions run inactive (one thread) while we call it: ScopedSingleThreadedOpenMp.

// CHOLMOD_AUTO: supernodal or simplicial. Derived to reach the factor for cholmod_updown
// (CholmodBase keeps it protected).
struct SparseSolver::Cholmod {
  struct Decomposition : Eigen::CholmodDecomposition<Matrix, Eigen::Upper> {
    cholmod_factor* factor() { return this->m_cholmodFactor; }
  };
  Decomposition llt;
};

SparseSolver::SparseSolver() : cholmod_(std::make_unique<Cholmod>()) {}
SparseSolver::~SparseSolver() = default;
SparseSolver::SparseSolver(SparseSolver&&) noexcept = default;
SparseSolver& SparseSolver::operator=(SparseSolver&&) noexcept = default;

std::vector<int> blockOrdering(int num_blocks, const std::vector<std::pair<int, int>>& pairs) {
  std::vector<int> order(static_cast<std::size_t>(num_blocks));
  if (num_blocks == 0) return order;
  // The block pattern, upper triangle, as CHOLMOD's AMD reads it (values unused).
  std::vector<std::vector<int>> rows(static_cast<std::size_t>(num_blocks));
  for (auto [a, b] : pairs) {
    if (a == b) continue;
    rows[static_cast<std::size_t>(std::max(a, b))].push_back(std::min(a, b));
  }
  std::vector<int> outer(static_cast<std::size_t>(num_blocks) + 1, 0);
  std::vector<int> inner;
  inner.reserve(pairs.size() + static_cast<std::size_t>(num_blocks));
  for (int c = 0; c < num_blocks; ++c) {
    auto& r = rows[static_cast<std::size_t>(c)];
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    inner.insert(inner.end(), r.begin(), r.end());
    inner.push_back(c);
    outer[static_cast<std::size_t>(c) + 1] = static_cast<int>(inner.size());
  }
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<std::size_t>(num_blocks);
  A.nzmax = inner.size();
  A.p = outer.data();
  A.i = inner.data();
  A.stype = 1;
  A.itype = CHOLMOD_INT;
  A.xtype = CHOLMOD_PATTERN;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = 1;
  cholmod_common common;
  cholmod_start(&common);
  const bool ok = cholmod_amd(&A, nullptr, 0, order.data(), &common) == 1;
  cholmod_finish(&common);
  if (!ok) std::iota(order.begin(), order.end(), 0);
  return order;
}

void SparseSolver::analyze(const Matrix& upper, bool preordered, Kind kind) {
  const ScopedSingleThreadedOpenMp single;
  cholmod_common& common = cholmod_->llt.cholmod();
  common.supernodal = kind == Kind::kSimplicial ? CHOLMOD_SIMPLICIAL : CHOLMOD_AUTO;
  if (preordered) {
    common.nmethods = 1;
    common.method[0].ordering = CHOLMOD_NATURAL;
    common.postorder = 0;  // keep the identity: no permuted copy of H per factorization
  } else {
    common.nmethods = 0;  // CHOLMOD's default strategy (AMD, METIS if that fills in badly)
    common.postorder = 1;
  }
  cholmod_->llt.analyzePattern(upper);
  ++analysis_count_;
  updated_ = reanalyze_ = factor_usable_ = false;
}

bool SparseSolver::factorize(const Matrix& upper) {
  const ScopedSingleThreadedOpenMp single;
  if (updated_) {
    if (reanalyze_) {
      cholmod_->llt.analyzePattern(upper);
      ++analysis_count_;
    } else {
      // Back to the symbolic simplicial factor (updates may have grown its pattern).
      cholmod_factor* L = cholmod_->llt.factor();
      cholmod_change_factor(CHOLMOD_PATTERN, 0, 0, 1, 1, L, &cholmod_->llt.cholmod());
    }
    updated_ = reanalyze_ = false;
  }
  cholmod_->llt.factorize(upper);
  factor_usable_ = cholmod_->llt.info() == Eigen::Success;
  return factor_usable_;
}

bool SparseSolver::update(const Matrix& C, bool add) {
  cholmod_factor* L = cholmod_->llt.factor();
  if (!factor_usable_ || L == nullptr || static_cast<Eigen::Index>(L->n) != C.rows()) return false;
  const ScopedSingleThreadedOpenMp single;
  cholmod_common& common = cholmod_->llt.cholmod();
  if (L->is_super) reanalyze_ = true;
  updated_ = true;
  factor_usable_ = false;
  // cholmod_updown works on the permuted system: rows of C go through the factor's ordering.
  cholmod_sparse c = Eigen::viewAsCholmod(const_cast<Matrix&>(C));
  cholmod_sparse* permuted = cholmod_submatrix(&c, static_cast<int*>(L->Perm),
                                               static_cast<long>(L->n), nullptr, -1, 1, 1, &common);
  if (permuted == nullptr) return false;
  const int ok = cholmod_updown(add ? 1 : 0, permuted, L, &common);
  cholmod_free_sparse(&permuted, &common);
  factor_usable_ = ok == 1 && common.status == CHOLMOD_OK && L->minor == L->n;
  if (factor_usable_ && !add) {
    // cholmod_updown does not report a downdate that loses positive definiteness: D of the
    // LDL' factor (each column's first entry) must stay positive.
    const auto* p = static_cast<const int*>(L->p);
    const auto* x = static_cast<const double*>(L->x);
    for (std::size_t j = 0; j < L->n && factor_usable_; ++j) factor_usable_ = x[p[j]] > 0.0;
  }
  return factor_usable_;
}

Eigen::VectorXd SparseSolver::solve(const Eigen::VectorXd& rhs) const {
  return cholmod_->llt.solve(rhs);
}

Eigen::MatrixXd SparseSolver::solve(const Eigen::MatrixXd& rhs) const {
  return cholmod_->llt.solve(rhs);
}

namespace {

// L^-1 e_k of a simplicial factor, as (row, value) pairs along the path from k to the root of
// the elimination tree (increasing rows): each column's diagonal entry comes first (D of LDL',
// unit L implied), and a column's parent is its smallest row below the diagonal. `work` is a
// zeroed dense vector of L's size, left zeroed.
std::vector<std::pair<int, double>> simplicialForwardSolveUnit(const cholmod_factor& L, int k,
                                                               std::vector<double>& work) {
  std::vector<std::pair<int, double>> path;
  const auto* p = static_cast<const int*>(L.p);
  const auto* i = static_cast<const int*>(L.i);
  const auto* nz = static_cast<const int*>(L.nz);
  const auto* x = static_cast<const double*>(L.x);
  work[static_cast<std::size_t>(k)] = 1.0;
  for (int j = k; j >= 0;) {
    const int start = p[j];
    double yj = work[static_cast<std::size_t>(j)];
    if (L.is_ll) yj /= x[start];
    path.emplace_back(j, yj);
    int next = -1;
    for (int q = start + 1; q < start + nz[j]; ++q) {
      work[static_cast<std::size_t>(i[q])] -= x[q] * yj;
      if (next < 0 || i[q] < next) next = i[q];
    }
    j = next;
  }
  for (const auto& [row, value] : path) work[static_cast<std::size_t>(row)] = 0.0;
  return path;
}

// Y = L^-1 [e_k for k in starts] of a supernodal (LL') factor, on the columns of the supernodes
// the paths from the starts to the root visit (the only rows it fills; slot[s] is where
// supernode s's columns begin), by one blocked forward solve: per supernode a triangular solve
// and a product for its rows below. The paths meet near the root, where the separators are
// dense blocks, so all columns go through them together.
Eigen::MatrixXd supernodalForwardSolve(const cholmod_factor& L, const std::vector<int>& starts) {
  const auto* super = static_cast<const int*>(L.super);
  const auto* pi = static_cast<const int*>(L.pi);
  const auto* px = static_cast<const int*>(L.px);
  const auto* rows = static_cast<const int*>(L.s);
  const auto* x = static_cast<const double*>(L.x);
  const auto nsuper = static_cast<int>(L.nsuper);
  auto supernode_of = [&](int column) {
    return static_cast<int>(std::upper_bound(super, super + nsuper + 1, column) - super) - 1;
  };
  auto columns_of = [&](int s) { return super[s + 1] - super[s]; };
  auto rows_of = [&](int s) { return pi[s + 1] - pi[s]; };
  std::vector<int> slot(static_cast<std::size_t>(nsuper), -1);
  std::vector<int> visited;
  for (int k : starts) {
    for (int s = supernode_of(k); s >= 0 && slot[static_cast<std::size_t>(s)] < 0;) {
      slot[static_cast<std::size_t>(s)] = 0;
      visited.push_back(s);
      s = rows_of(s) > columns_of(s) ? supernode_of(rows[pi[s] + columns_of(s)]) : -1;
    }
  }
  std::sort(visited.begin(), visited.end());  // children before parents
  int height = 0;
  for (int s : visited) {
    slot[static_cast<std::size_t>(s)] = height;
    height += columns_of(s);
  }
  auto row_slot = [&](int column) {
    const int s = supernode_of(column);
    return slot[static_cast<std::size_t>(s)] + column - super[s];
  };
  Eigen::MatrixXd Y = Eigen::MatrixXd::Zero(height, static_cast<Eigen::Index>(starts.size()));
  for (std::size_t a = 0; a < starts.size(); ++a)
    Y(row_slot(starts[a]), static_cast<Eigen::Index>(a)) = 1.0;
  Eigen::MatrixXd below;
  for (int s : visited) {
    const int ncols = columns_of(s);
    const int nrows = rows_of(s);
    const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> block(
        x + px[s], nrows, ncols, Eigen::OuterStride<>(nrows));
    auto Ys = Y.middleRows(slot[static_cast<std::size_t>(s)], ncols);
    block.topRows(ncols).triangularView<Eigen::Lower>().solveInPlace(Ys);
    if (nrows == ncols) continue;
    below.noalias() = block.bottomRows(nrows - ncols) * Ys;
    for (int r = 0; r < nrows - ncols; ++r)
      Y.row(row_slot(rows[pi[s] + ncols + r])) -= below.row(r);
  }
  return Y;
}

}  // namespace

Eigen::MatrixXd SparseSolver::inverseSubmatrix(const std::vector<int>& indices) const {
  const auto m = static_cast<Eigen::Index>(indices.size());
  const cholmod_factor* L = cholmod_->llt.factor();
  if (!factor_usable_ || L == nullptr || m == 0) return Eigen::MatrixXd::Zero(m, m);
  const auto n = static_cast<std::size_t>(L->n);
  std::vector<int> starts;  // the rows of P A P' that `indices` become
  starts.reserve(indices.size());
  const auto* perm = static_cast<const int*>(L->Perm);
  if (perm == nullptr) {
    starts = indices;
  } else {
    std::vector<int> position(n);
    for (std::size_t k = 0; k < n; ++k)
      position[static_cast<std::size_t>(perm[k])] = static_cast<int>(k);
    for (int index : indices) starts.push_back(position[static_cast<std::size_t>(index)]);
  }
  if (L->is_super) {
    const Eigen::MatrixXd Y = supernodalForwardSolve(*L, starts);
    return Y.transpose() * Y;
  }
  // Simplicial: Y on the union of the paths, each row scaled by D^-1/2 of an LDL' factor.
  std::vector<double> work(n, 0.0);
  std::vector<std::vector<std::pair<int, double>>> columns;
  columns.reserve(starts.size());
  for (int k : starts) columns.push_back(simplicialForwardSolveUnit(*L, k, work));
  const auto* p = static_cast<const int*>(L->p);
  const auto* x = static_cast<const double*>(L->x);
  std::vector<int> slot(n, -1);
  int height = 0;
  for (const auto& column : columns) {
    for (const auto& entry : column) {
      if (slot[static_cast<std::size_t>(entry.first)] < 0)
        slot[static_cast<std::size_t>(entry.first)] = height++;
    }
  }
  Eigen::MatrixXd Y = Eigen::MatrixXd::Zero(height, m);
  for (Eigen::Index a = 0; a < m; ++a) {
    for (const auto& [row, value] : columns[static_cast<std::size_t>(a)]) {
      const double scale = L->is_ll ? 1.0 : 1.0 / std::sqrt(x[p[row]]);
      Y(slot[static_cast<std::size_t>(row)], a) = value * scale;
    }
  }
  return Y.transpose() * Y;
}

}  // namespace rrr_graphslam::core
