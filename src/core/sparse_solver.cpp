#include "rrr_graphslam/core/sparse_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

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

namespace {

// The upper triangle of the block pattern as CHOLMOD reads it (values unused). Owns the arrays
// the cholmod_sparse view points into.
struct BlockPattern {
  std::vector<int> outer, inner;
  cholmod_sparse view{};

  BlockPattern(const BlockPattern&) = delete;
  BlockPattern& operator=(const BlockPattern&) = delete;
  BlockPattern(int num_blocks, const std::vector<std::pair<int, int>>& pairs) {
    std::vector<std::vector<int>> rows(static_cast<std::size_t>(num_blocks));
    for (auto [a, b] : pairs) {
      if (a == b) continue;
      rows[static_cast<std::size_t>(std::max(a, b))].push_back(std::min(a, b));
    }
    outer.assign(static_cast<std::size_t>(num_blocks) + 1, 0);
    inner.reserve(pairs.size() + static_cast<std::size_t>(num_blocks));
    for (int c = 0; c < num_blocks; ++c) {
      auto& r = rows[static_cast<std::size_t>(c)];
      std::sort(r.begin(), r.end());
      r.erase(std::unique(r.begin(), r.end()), r.end());
      inner.insert(inner.end(), r.begin(), r.end());
      inner.push_back(c);
      outer[static_cast<std::size_t>(c) + 1] = static_cast<int>(inner.size());
    }
    view.nrow = view.ncol = static_cast<std::size_t>(num_blocks);
    view.nzmax = inner.size();
    view.p = outer.data();
    view.i = inner.data();
    view.stype = 1;
    view.itype = CHOLMOD_INT;
    view.xtype = CHOLMOD_PATTERN;
    view.dtype = CHOLMOD_DOUBLE;
    view.sorted = 1;
    view.packed = 1;
  }
};

struct OrderingResult {
  bool ok = false;
  std::vector<int> order;
  double flops = 0, factor_nonzeros = 0;
  bool nested_dissection = false;  // what CHOLMOD used (METIS falls back to AMD on dense graphs)
};

// One ordering method and the symbolic factorization it gives (its flop count and nnz(L)).
OrderingResult orderBy(cholmod_sparse& pattern, int method) {
  OrderingResult result;
  cholmod_common common;
  cholmod_start(&common);
  common.nmethods = 1;
  common.method[0].ordering = method;
  // AMD's order exactly as cholmod_amd gives it; METIS's postordered (its separators' subtrees
  // in one piece each, as CHOLMOD's own analysis would: larger supernodes).
  common.postorder = method == CHOLMOD_METIS ? 1 : 0;
  common.supernodal = CHOLMOD_SIMPLICIAL;  // the counts are all we need
  cholmod_factor* L = cholmod_analyze(&pattern, &common);
  if (L != nullptr && common.status == CHOLMOD_OK) {
    const int* perm = static_cast<const int*>(L->Perm);
    result.order.assign(perm, perm + L->n);
    result.flops = common.fl;
    result.factor_nonzeros = common.lnz;
    result.nested_dissection = L->ordering == CHOLMOD_METIS;
    result.ok = true;
  }
  cholmod_free_factor(&L, &common);
  cholmod_finish(&common);
  return result;
}

}  // namespace

BlockOrdering blockOrdering(int num_blocks, const std::vector<std::pair<int, int>>& pairs,
                            BlockOrdering::Method method) {
  BlockOrdering result;
  result.order.resize(static_cast<std::size_t>(num_blocks));
  std::iota(result.order.begin(), result.order.end(), 0);
  if (num_blocks == 0) return result;
  BlockPattern pattern(num_blocks, pairs);
  auto take = [&result](OrderingResult& o) {
    result.order = std::move(o.order);
    result.flops = o.flops;
    result.nested_dissection = o.nested_dissection;
  };
  if (method == BlockOrdering::Method::kNestedDissection) {
    OrderingResult metis = orderBy(pattern.view, CHOLMOD_METIS);
    if (metis.ok) take(metis);
    return result;
  }
  OrderingResult amd = orderBy(pattern.view, CHOLMOD_AMD);
  if (!amd.ok) return result;
  const double amd_flops = amd.flops, amd_nonzeros = amd.factor_nonzeros;
  take(amd);
  if (method == BlockOrdering::Method::kAmd) return result;
  // CHOLMOD's own rule for when AMD's ordering fills in badly enough to try METIS (fl/lnz >= 500
  // and lnz/nnz(A) >= 5 on the scalar matrix), on the block graph: a 3x3 block stands for 9
  // nonzeros and 27 flops, so the scalar fl/lnz is about 3 times the block one. Long links
  // between distant parts of a graph (false loops in groups, before the robust map switches
  // them off) fill AMD's factor 3 times more than nested dissection's: City10000 + 2000 false
  // loops in groups of 20 factor in 0.44 s instead of 1.38 s.
  const double pattern_nonzeros = static_cast<double>(pattern.inner.size());
  const bool fills_in = 3 * amd_flops >= 500 * amd_nonzeros && amd_nonzeros >= 5 * pattern_nonzeros;
  if (!fills_in) return result;
  OrderingResult metis = orderBy(pattern.view, CHOLMOD_METIS);
  if (metis.ok && metis.flops < amd_flops) take(metis);
  return result;
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
  rememberAnalysisFlops();
  updated_ = reanalyze_ = factor_usable_ = false;
}

void SparseSolver::rememberAnalysisFlops() {
  const double flops = cholmod_->llt.cholmod().fl;
  analysis_flops_ = std::isfinite(flops) && flops > 0.0 ? flops : 0.0;
}

bool SparseSolver::factorize(const Matrix& upper) {
  const ScopedSingleThreadedOpenMp single;
  if (updated_) {
    if (reanalyze_) {
      cholmod_->llt.analyzePattern(upper);
      ++analysis_count_;
      rememberAnalysisFlops();
    } else {
      // Back to the symbolic simplicial factor (updates may have grown its pattern).
      cholmod_factor* L = cholmod_->llt.factor();
      cholmod_change_factor(CHOLMOD_PATTERN, 0, 0, 1, 1, L, &cholmod_->llt.cholmod());
    }
    updated_ = reanalyze_ = false;
  }
  const auto start = std::chrono::steady_clock::now();
  cholmod_->llt.factorize(upper);
  factor_usable_ = cholmod_->llt.info() == Eigen::Success;
  ++work_.factorizations;
  work_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  work_.flops += analysis_flops_;
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

// A column of a sparse right-hand side: (row of P A P', value) pairs.
using SparseColumn = std::vector<std::pair<int, double>>;

// The lower triangle of `lower` mirrored into its upper one.
Eigen::MatrixXd symmetricFromLower(const Eigen::MatrixXd& lower) {
  Eigen::MatrixXd out = lower.selfadjointView<Eigen::Lower>();
  return out;
}

// B' A^-1 B for a simplicial factor P A P' = L D L' (or L L'): each column y = L^-1 b, scaled by
// D^-1/2, is nonzero only on the union of the paths from b's rows to the root of the elimination
// tree (a column's parent is its smallest row below the diagonal), walked in increasing order.
Eigen::MatrixXd simplicialInverseProjection(const cholmod_factor& L,
                                            const std::vector<SparseColumn>& columns) {
  const auto* p = static_cast<const int*>(L.p);
  const auto* i = static_cast<const int*>(L.i);
  const auto* nz = static_cast<const int*>(L.nz);
  const auto* x = static_cast<const double*>(L.x);
  const auto n = static_cast<std::size_t>(L.n);
  auto parent = [&](int j) {
    int next = -1;
    for (int q = p[j] + 1; q < p[j] + nz[j]; ++q) {
      if (next < 0 || i[q] < next) next = i[q];
    }
    return next;
  };
  std::vector<double> work(n, 0.0);
  std::vector<char> on_path(n, 0);
  std::vector<int> slot(n, -1);  // the row of Y a row of L takes
  std::vector<int> slot_row;     // and back
  std::vector<SparseColumn> ys;
  ys.reserve(columns.size());
  for (const SparseColumn& b : columns) {
    std::vector<int> path;
    for (const auto& entry : b) {
      for (int j = entry.first; j >= 0 && !on_path[static_cast<std::size_t>(j)]; j = parent(j)) {
        on_path[static_cast<std::size_t>(j)] = 1;
        path.push_back(j);
      }
      work[static_cast<std::size_t>(entry.first)] += entry.second;
    }
    std::sort(path.begin(), path.end());  // children before parents
    SparseColumn y;
    y.reserve(path.size());
    for (int j : path) {
      double yj = work[static_cast<std::size_t>(j)];
      if (L.is_ll) yj /= x[p[j]];
      for (int q = p[j] + 1; q < p[j] + nz[j]; ++q)
        work[static_cast<std::size_t>(i[q])] -= x[q] * yj;
      y.emplace_back(j, L.is_ll ? yj : yj / std::sqrt(x[p[j]]));
      work[static_cast<std::size_t>(j)] = 0.0;
      on_path[static_cast<std::size_t>(j)] = 0;
      if (slot[static_cast<std::size_t>(j)] < 0) {
        slot[static_cast<std::size_t>(j)] = static_cast<int>(slot_row.size());
        slot_row.push_back(j);
      }
    }
    ys.push_back(std::move(y));
  }
  Eigen::MatrixXd Y = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(slot_row.size()),
                                            static_cast<Eigen::Index>(columns.size()));
  for (std::size_t a = 0; a < ys.size(); ++a) {
    for (const auto& [row, value] : ys[a])
      Y(slot[static_cast<std::size_t>(row)], static_cast<Eigen::Index>(a)) = value;
  }
  Eigen::MatrixXd lower = Eigen::MatrixXd::Zero(Y.cols(), Y.cols());
  lower.selfadjointView<Eigen::Lower>().rankUpdate(Y.transpose());
  return symmetricFromLower(lower);
}

// B' A^-1 B for a supernodal factor P A P' = L L' by one blocked forward solve Y = L^-1 B on the
// supernodes the paths from B's rows to the root visit (the only rows Y fills), children before
// parents: per supernode a triangular solve and a product for its rows below, then its rows'
// share of Y' Y. The paths meet near the root, where the separators are dense blocks, so all
// columns go through them together. Lower down a supernode is on the paths of only some
// columns: with the columns sorted by the first supernode they reach, a range [lo, hi] covers
// them, and the solve works on that range alone (a loop's two ends climb separate subtrees until
// they meet; columns in the range whose paths miss the supernode are zero there and stay zero).
// Y is kept transposed (a column of Yt per row of L), so each scattered row is contiguous.
Eigen::MatrixXd supernodalInverseProjection(const cholmod_factor& L,
                                            const std::vector<SparseColumn>& columns) {
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
  auto parent_of = [&](int s) {
    return rows_of(s) > columns_of(s) ? supernode_of(rows[pi[s] + columns_of(s)]) : -1;
  };
  const auto k = static_cast<int>(columns.size());
  // Columns in the order of the first supernode they reach.
  std::vector<int> first(static_cast<std::size_t>(k), nsuper);
  for (int a = 0; a < k; ++a) {
    for (const auto& entry : columns[static_cast<std::size_t>(a)])
      first[static_cast<std::size_t>(a)] =
          std::min(first[static_cast<std::size_t>(a)], supernode_of(entry.first));
  }
  std::vector<int> order(static_cast<std::size_t>(k));  // order[position] = column
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return first[static_cast<std::size_t>(a)] < first[static_cast<std::size_t>(b)];
  });
  // The supernodes visited, and per supernode the range of positions whose paths reach it.
  std::vector<int> slot(static_cast<std::size_t>(nsuper), -1);
  std::vector<int> lo(static_cast<std::size_t>(nsuper), k),
      hi(static_cast<std::size_t>(nsuper), -1);
  std::vector<int> visited;
  for (int position = 0; position < k; ++position) {
    for (const auto& entry :
         columns[static_cast<std::size_t>(order[static_cast<std::size_t>(position)])]) {
      const int start = supernode_of(entry.first);
      lo[static_cast<std::size_t>(start)] = std::min(lo[static_cast<std::size_t>(start)], position);
      hi[static_cast<std::size_t>(start)] = std::max(hi[static_cast<std::size_t>(start)], position);
      for (int s = start; s >= 0 && slot[static_cast<std::size_t>(s)] < 0; s = parent_of(s)) {
        slot[static_cast<std::size_t>(s)] = 0;
        visited.push_back(s);
      }
    }
  }
  std::sort(visited.begin(), visited.end());  // children before parents
  int height = 0;
  for (int s : visited) {
    slot[static_cast<std::size_t>(s)] = height;
    height += columns_of(s);
    const int parent = parent_of(s);
    if (parent < 0) continue;
    lo[static_cast<std::size_t>(parent)] =
        std::min(lo[static_cast<std::size_t>(parent)], lo[static_cast<std::size_t>(s)]);
    hi[static_cast<std::size_t>(parent)] =
        std::max(hi[static_cast<std::size_t>(parent)], hi[static_cast<std::size_t>(s)]);
  }
  auto row_slot = [&](int column) {
    const int s = supernode_of(column);
    return slot[static_cast<std::size_t>(s)] + column - super[s];
  };
  Eigen::MatrixXd Yt = Eigen::MatrixXd::Zero(k, height);
  for (int position = 0; position < k; ++position) {
    for (const auto& [row, value] :
         columns[static_cast<std::size_t>(order[static_cast<std::size_t>(position)])])
      Yt(position, row_slot(row)) += value;
  }
  Eigen::MatrixXd lower = Eigen::MatrixXd::Zero(k, k);  // Y'Y by positions, lower triangle
  Eigen::MatrixXd below;
  for (int s : visited) {
    const int ncols = columns_of(s);
    const int nrows = rows_of(s);
    const int from = lo[static_cast<std::size_t>(s)];
    const int width = hi[static_cast<std::size_t>(s)] - from + 1;
    const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> block(
        x + px[s], nrows, ncols, Eigen::OuterStride<>(nrows));
    auto Ys =
        Yt.block(from, slot[static_cast<std::size_t>(s)], width, ncols);  // Y's rows, transposed
    // Y_s = L_ss^-1 Y_s, i.e. Yt_s = Yt_s L_ss^-T.
    block.topRows(ncols).triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(
        Ys);
    lower.block(from, from, width, width).selfadjointView<Eigen::Lower>().rankUpdate(Ys);
    if (nrows == ncols) continue;
    below.noalias() = Ys * block.bottomRows(nrows - ncols).transpose();
    for (int r = 0; r < nrows - ncols; ++r)
      Yt.block(from, row_slot(rows[pi[s] + ncols + r]), width, 1) -= below.col(r);
  }
  // Back from positions to the columns' own order.
  const Eigen::MatrixXd by_position = symmetricFromLower(lower);
  Eigen::MatrixXd out(k, k);
  for (int a = 0; a < k; ++a) {
    for (int b = 0; b < k; ++b)
      out(order[static_cast<std::size_t>(a)], order[static_cast<std::size_t>(b)]) =
          by_position(a, b);
  }
  return out;
}

}  // namespace

int SparseSolver::dimension() const {
  const cholmod_factor* L = cholmod_->llt.factor();
  return L == nullptr ? 0 : static_cast<int>(L->n);
}

bool SparseSolver::supernodal() const {
  const cholmod_factor* L = cholmod_->llt.factor();
  return L != nullptr && L->is_super;
}

Eigen::MatrixXd SparseSolver::inverseProjection(const Matrix& B) const {
  const cholmod_factor* L = cholmod_->llt.factor();
  const auto k = static_cast<Eigen::Index>(B.cols());
  if (!factor_usable_ || L == nullptr || k == 0) return Eigen::MatrixXd::Zero(k, k);
  const auto n = static_cast<std::size_t>(L->n);
  if (static_cast<std::size_t>(B.rows()) != n) {
    throw std::invalid_argument("SparseSolver::inverseProjection: B has " +
                                std::to_string(B.rows()) + " rows, the factor " +
                                std::to_string(n));
  }
  // B's rows as rows of P A P'.
  std::vector<int> position(n);
  const auto* perm = static_cast<const int*>(L->Perm);
  for (std::size_t r = 0; r < n; ++r)
    position[static_cast<std::size_t>(perm != nullptr ? perm[r] : static_cast<int>(r))] =
        static_cast<int>(r);
  std::vector<SparseColumn> columns(static_cast<std::size_t>(k));
  for (Eigen::Index c = 0; c < k; ++c) {
    for (Matrix::InnerIterator it(B, c); it; ++it) {
      if (it.value() != 0.0)
        columns[static_cast<std::size_t>(c)].emplace_back(
            position[static_cast<std::size_t>(it.row())], it.value());
    }
  }
  return L->is_super ? supernodalInverseProjection(*L, columns)
                     : simplicialInverseProjection(*L, columns);
}

Eigen::MatrixXd SparseSolver::inverseSubmatrix(const std::vector<int>& indices) const {
  const cholmod_factor* L = cholmod_->llt.factor();
  const auto m = static_cast<Eigen::Index>(indices.size());
  if (!factor_usable_ || L == nullptr || m == 0) return Eigen::MatrixXd::Zero(m, m);
  std::vector<Eigen::Triplet<double>> units;
  units.reserve(indices.size());
  for (Eigen::Index a = 0; a < m; ++a)
    units.emplace_back(indices[static_cast<std::size_t>(a)], a, 1.0);
  Matrix E(static_cast<Eigen::Index>(L->n), m);
  E.setFromTriplets(units.begin(), units.end());
  return inverseProjection(E);
}

}  // namespace rrr_graphslam::core
