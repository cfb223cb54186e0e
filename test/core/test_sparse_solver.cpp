// The block ordering against the elimination game, and CHOLMOD through SparseSolver: solves against
// a dense Cholesky, and rank updates / downdates of the factor against a dense solve of the updated
// matrix, for a simplicial and a supernodal factor.

#include <gtest/gtest.h>

#include <Eigen/CholmodSupport>
#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "rrr_graphslam/core/sparse_solver.h"

namespace rrr_graphslam::core {
namespace {

using Matrix = SparseSolver::Matrix;

// A random SPD matrix with a band of `band` off-diagonals plus `extra` random couplings (upper
// triangle stored), as a pose graph's H looks after a fill-reducing ordering.
Eigen::MatrixXd randomSpd(int n, int band, int extra, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, n - 1);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j <= std::min(n - 1, i + band); ++j) A(i, j) = A(j, i) = u(rng);
  }
  for (int k = 0; k < extra; ++k) {
    const int i = pick(rng), j = pick(rng);
    if (i != j) A(i, j) = A(j, i) = u(rng);
  }
  // Diagonally dominant: positive definite.
  for (int i = 0; i < n; ++i) A(i, i) = A.row(i).cwiseAbs().sum() + 1.0;
  return A;
}

Matrix upper(const Eigen::MatrixXd& A) {
  const Matrix full = A.sparseView();
  Matrix S = full.triangularView<Eigen::Upper>();
  S.makeCompressed();
  return S;
}

Matrix randomColumns(int n, int k, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, n - 1);
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, k);
  for (int c = 0; c < k; ++c) {
    for (int e = 0; e < 6; ++e) C(pick(rng), c) = u(rng);
  }
  Matrix S = C.sparseView();
  S.makeCompressed();
  return S;
}

// Size (30: simplicial, 600: supernodal unless forced simplicial), whether CHOLMOD orders the
// matrix (false) or takes it as ordered (true, as the optimizer calls it), and the factor kind.
class RankUpdates : public ::testing::TestWithParam<std::tuple<int, bool, SparseSolver::Kind>> {};

TEST_P(RankUpdates, UpdateAndDowndateMatchDenseSolves) {
  const auto [n, preordered, kind] = GetParam();
  // Wide bands and many couplings make CHOLMOD choose a supernodal factor for the larger size.
  const Eigen::MatrixXd A = randomSpd(n, n > 100 ? 40 : 3, n, 5);
  const Matrix C = randomColumns(n, 9, 6);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  const Eigen::MatrixXd Cd = Eigen::MatrixXd(C);

  SparseSolver solver;
  EXPECT_FALSE(solver.update(C, true)) << "no factorization to update yet";
  solver.analyze(upper(A), preordered, kind);
  ASSERT_TRUE(solver.factorize(upper(A)));
  EXPECT_LT((solver.solve(b) - A.llt().solve(b)).norm(), 1e-9 * b.norm());

  ASSERT_TRUE(solver.update(C, true));
  const Eigen::MatrixXd A_plus = A + Cd * Cd.transpose();
  EXPECT_LT((solver.solve(b) - A_plus.llt().solve(b)).norm(), 1e-9 * b.norm());
  // Several right-hand sides at once (marginal covariances).
  const Eigen::MatrixXd B = Eigen::MatrixXd::Identity(n, 4);
  EXPECT_LT((solver.solve(B) - A_plus.llt().solve(B)).norm(), 1e-9);

  ASSERT_TRUE(solver.update(C, false));
  EXPECT_LT((solver.solve(b) - A.llt().solve(b)).norm(), 1e-9 * b.norm());

  // A fresh factorization after updates solves the new matrix. Only the supernodal factor
  // (converted to simplicial by the updates) needs its pattern analyzed again.
  ASSERT_TRUE(solver.factorize(upper(A_plus)));
  EXPECT_LT((solver.solve(b) - A_plus.llt().solve(b)).norm(), 1e-9 * b.norm());
  const bool supernodal = n > 100 && kind == SparseSolver::Kind::kAuto;
  EXPECT_EQ(solver.analysisCount(), supernodal ? 2 : 1);

  // Entries of the inverse by path-restricted forward solves, against full solves, on the
  // factorization and after a rank update (simplicial LDL' then, whatever it was before).
  const std::vector<int> picked = {0, 1, n / 3, n / 2, n - 2, n - 1};
  auto expected_inverse = [&](const Eigen::MatrixXd& M) {
    const Eigen::MatrixXd inverse = M.inverse();
    Eigen::MatrixXd out(picked.size(), picked.size());
    for (std::size_t a = 0; a < picked.size(); ++a) {
      for (std::size_t c = 0; c < picked.size(); ++c) out(a, c) = inverse(picked[a], picked[c]);
    }
    return out;
  };
  const Eigen::MatrixXd inverse_plus = expected_inverse(A_plus);
  EXPECT_LT((solver.inverseSubmatrix(picked) - inverse_plus).norm(), 1e-9 * inverse_plus.norm());
  ASSERT_TRUE(solver.factorize(upper(A)));
  const Eigen::MatrixXd inverse_a = expected_inverse(A);
  EXPECT_LT((solver.inverseSubmatrix(picked) - inverse_a).norm(), 1e-9 * inverse_a.norm());
  EXPECT_EQ(solver.inverseSubmatrix({}).size(), 0);

  // A downdate that leaves no positive-definite matrix fails, and a factorization recovers.
  const Matrix big =
      Matrix((10.0 * Eigen::MatrixXd::Identity(n, 2) * std::sqrt(A.maxCoeff() * n)).sparseView());
  EXPECT_FALSE(solver.update(big, false));
  ASSERT_TRUE(solver.factorize(upper(A)));
  EXPECT_LT((solver.solve(b) - A.llt().solve(b)).norm(), 1e-9 * b.norm());
}

// B' A^-1 B by path-restricted forward solves, against the dense inverse (the slow, obvious
// version): columns with several entries whose paths meet only near the root, a column of one
// entry, an empty column, a column that repeats another; on the factorization and after a rank
// update (simplicial LDL' then, whatever it was before).
TEST_P(RankUpdates, InverseProjectionMatchesTheDenseInverse) {
  const auto [n, preordered, kind] = GetParam();
  const Eigen::MatrixXd A = randomSpd(n, n > 100 ? 40 : 3, n, 7);
  Eigen::MatrixXd Bd = Eigen::MatrixXd(randomColumns(n, 12, 8));
  Bd.col(3).setZero();
  Bd.col(4).setZero();
  Bd(n - 1, 4) = 2.0;
  Bd.col(5) = Bd.col(0);
  Bd(0, 6) = 1.0;  // the two ends of the order
  Bd(n - 1, 6) = -1.0;
  const Matrix B = Matrix(Bd.sparseView());
  SparseSolver solver;
  EXPECT_EQ(solver.inverseProjection(B).norm(), 0.0) << "no factorization yet";
  solver.analyze(upper(A), preordered, kind);
  ASSERT_TRUE(solver.factorize(upper(A)));
  EXPECT_EQ(solver.dimension(), n);
  const Eigen::MatrixXd expected = Bd.transpose() * A.inverse() * Bd;
  const Eigen::MatrixXd got = solver.inverseProjection(B);
  ASSERT_EQ(got.rows(), B.cols());
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm());
  EXPECT_EQ((got - got.transpose()).norm(), 0.0);
  EXPECT_EQ(got.row(3).norm(), 0.0);
  EXPECT_EQ(solver.inverseProjection(Matrix(n, 0)).size(), 0);
  EXPECT_THROW(solver.inverseProjection(Matrix(n + 1, 2)), std::invalid_argument);

  const Matrix C = randomColumns(n, 5, 9);
  ASSERT_TRUE(solver.update(C, true));
  const Eigen::MatrixXd A_plus = A + Eigen::MatrixXd(C) * Eigen::MatrixXd(C).transpose();
  const Eigen::MatrixXd expected_plus = Bd.transpose() * A_plus.inverse() * Bd;
  EXPECT_LT((solver.inverseProjection(B) - expected_plus).norm(), 1e-9 * expected_plus.norm());
}

// A 2-D grid (a pose graph of many loops looks like one after ordering): a supernodal factor
// whose elimination tree branches, and columns whose entries sit in leaves far apart (a loop
// link's two ends), so each supernode is solved for a different range of columns.
TEST(InverseProjection, ColumnsWhosePathsMeetOnlyNearTheRootOfASupernodalFactor) {
  const int side = 30, n = side * side;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  auto at = [&](int r, int c) { return r * side + c; };
  // Each point coupled to those within 2 rows and columns: dense enough for supernodes.
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      for (int dr = 0; dr <= 2 && r + dr < side; ++dr) {
        for (int dc = -2; dc <= 2; ++dc) {
          if ((dr == 0 && dc <= 0) || c + dc < 0 || c + dc >= side) continue;
          A(at(r, c), at(r + dr, c + dc)) = A(at(r + dr, c + dc), at(r, c)) =
              -1.0 / (dr + std::abs(dc));
        }
      }
    }
  }
  for (int i = 0; i < n; ++i) A(i, i) = A.row(i).cwiseAbs().sum() + 0.1;
  Eigen::MatrixXd Bd = Eigen::MatrixXd::Zero(n, 8);
  Bd(at(0, 0), 0) = 1.0;  // opposite corners
  Bd(at(29, 29), 0) = -1.0;
  Bd(at(0, 29), 1) = 0.5;  // the other two
  Bd(at(29, 0), 1) = 2.0;
  Bd(at(1, 1), 2) = 1.0;    // beside column 0's first end
  Bd(at(15, 15), 3) = 1.0;  // the middle, alone
  Bd(at(3, 27), 4) = 1.0;   // three places
  Bd(at(27, 3), 4) = -1.0;
  Bd(at(14, 2), 4) = 0.7;
  Bd(at(28, 28), 5) = 1.0;  // beside column 0's second end
  Bd(at(0, 0), 6) = 1.0;    // column 0 again, one end only
  Bd(at(5, 9), 7) = 1.0;
  Bd(at(6, 9), 7) = 1.0;
  SparseSolver solver;
  solver.analyze(upper(A));
  ASSERT_TRUE(solver.factorize(upper(A)));
  ASSERT_TRUE(solver.supernodal()) << "the grid should factor supernodally";
  const Eigen::MatrixXd expected = Bd.transpose() * A.inverse() * Bd;
  const Eigen::MatrixXd got = solver.inverseProjection(Matrix(Bd.sparseView()));
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm());
  // The same through unit columns, one at a time and all at once.
  const std::vector<int> picked = {at(0, 0), at(29, 29), at(15, 15), at(0, 29)};
  const Eigen::MatrixXd inverse = A.inverse();
  const Eigen::MatrixXd together = solver.inverseSubmatrix(picked);
  for (std::size_t a = 0; a < picked.size(); ++a) {
    for (std::size_t b = 0; b < picked.size(); ++b) {
      EXPECT_NEAR(together(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)),
                  inverse(picked[a], picked[b]), 1e-9 * inverse.norm());
    }
    EXPECT_NEAR(solver.inverseSubmatrix({picked[a]})(0, 0), inverse(picked[a], picked[a]),
                1e-9 * inverse.norm());
  }
}

// The slow, obvious symbolic factorization: eliminate the blocks in `order` one by one, each
// joining its remaining neighbours into a clique (the elimination game, on a dense adjacency
// matrix). Returns the flop count sum over columns of c^2, c = the column's nonzeros in L with
// its diagonal (CHOLMOD's fl for a symmetric matrix).
double eliminationFlops(int n, const std::vector<std::pair<int, int>>& pairs,
                        const std::vector<int>& order) {
  const auto size = static_cast<std::size_t>(n);
  std::vector<char> adjacent(size * size, 0);
  for (auto [a, b] : pairs) {
    adjacent[static_cast<std::size_t>(a) * size + static_cast<std::size_t>(b)] = 1;
    adjacent[static_cast<std::size_t>(b) * size + static_cast<std::size_t>(a)] = 1;
  }
  std::vector<char> eliminated(size, 0);
  double flops = 0;
  for (const int v : order) {
    eliminated[static_cast<std::size_t>(v)] = 1;
    std::vector<std::size_t> rest;
    for (std::size_t w = 0; w < size; ++w) {
      if (!eliminated[w] && adjacent[static_cast<std::size_t>(v) * size + w]) rest.push_back(w);
    }
    const double c = static_cast<double>(rest.size()) + 1.0;
    flops += c * c;
    for (const std::size_t a : rest) {
      for (const std::size_t b : rest) adjacent[a * size + b] = 1;
    }
  }
  return flops;
}

bool isPermutation(std::vector<int> order, int n) {
  std::sort(order.begin(), order.end());
  for (int k = 0; k < n; ++k) {
    if (order[static_cast<std::size_t>(k)] != k) return false;
  }
  return static_cast<int>(order.size()) == n;
}

// A street grid walked row by row (odometry) with a loop at every crossing of two streets: a
// pose graph whose AMD order fills in little.
std::vector<std::pair<int, int>> gridGraph(int side) {
  std::vector<std::pair<int, int>> pairs;
  auto at = [side](int r, int c) { return r * side + c; };
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      if (c + 1 < side) pairs.emplace_back(at(r, c), at(r, c + 1));
      if (r + 1 < side) pairs.emplace_back(at(r, c), at(r + 1, c));
    }
  }
  return pairs;
}

TEST(BlockOrdering, AGraphThatFillsInLittleKeepsAmd) {
  const int side = 40, n = side * side;
  const auto pairs = gridGraph(side);
  const BlockOrdering ordering = blockOrdering(n, pairs);
  ASSERT_TRUE(isPermutation(ordering.order, n));
  EXPECT_FALSE(ordering.nested_dissection);
  const BlockOrdering amd = blockOrdering(n, pairs, BlockOrdering::Method::kAmd);
  EXPECT_EQ(ordering.order, amd.order);
  // CHOLMOD's flop count is the elimination game's.
  EXPECT_DOUBLE_EQ(ordering.flops, eliminationFlops(n, pairs, ordering.order));
}

TEST(BlockOrdering, LongLinksBetweenDistantPartsTakeNestedDissection) {
  // The street grid, and groups of 5 parallel links between random stretches of it: what
  // groups of false loops do to a pose graph.
  const int side = 60, n = side * side, groups = 100, group_size = 5;
  std::vector<std::pair<int, int>> pairs = gridGraph(side);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> start(0, n - group_size - 1);
  for (int g = 0; g < groups; ++g) {
    const int a = start(rng), b = start(rng);
    for (int k = 0; k < group_size; ++k) pairs.emplace_back(a + k, b + k);
  }
  const BlockOrdering ordering = blockOrdering(n, pairs);
  const BlockOrdering amd = blockOrdering(n, pairs, BlockOrdering::Method::kAmd);
  const BlockOrdering nd = blockOrdering(n, pairs, BlockOrdering::Method::kNestedDissection);
  ASSERT_TRUE(isPermutation(ordering.order, n));
  ASSERT_TRUE(isPermutation(nd.order, n));
  EXPECT_TRUE(ordering.nested_dissection);
  EXPECT_EQ(ordering.order, nd.order);
  EXPECT_LT(ordering.flops, 0.7 * amd.flops);
  EXPECT_DOUBLE_EQ(amd.flops, eliminationFlops(n, pairs, amd.order));
  EXPECT_DOUBLE_EQ(nd.flops, eliminationFlops(n, pairs, nd.order));
  // METIS is seeded: the same graph gets the same order.
  EXPECT_EQ(blockOrdering(n, pairs).order, ordering.order);
}

// The AMD order is the one cholmod_amd gives (the optimizer's order before nested dissection
// was added): decisions made with it stay as they were.
TEST(BlockOrdering, AmdIsCholmodAmdsOrder) {
  const int side = 30, n = side * side;
  auto pairs = gridGraph(side);
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> node(0, n - 1);
  for (int k = 0; k < 40; ++k) pairs.emplace_back(node(rng), node(rng));
  Eigen::SparseMatrix<double> pattern(n, n);
  std::vector<Eigen::Triplet<double>> entries;
  for (int k = 0; k < n; ++k) entries.emplace_back(k, k, 1.0);
  for (auto [a, b] : pairs) {
    if (a != b) entries.emplace_back(std::min(a, b), std::max(a, b), 1.0);
  }
  pattern.setFromTriplets(entries.begin(), entries.end());
  pattern.makeCompressed();
  cholmod_sparse view = Eigen::viewAsCholmod(pattern);
  view.stype = 1;  // the upper triangle of a symmetric matrix
  cholmod_common common;
  cholmod_start(&common);
  std::vector<int> expected(static_cast<std::size_t>(n));
  ASSERT_EQ(cholmod_amd(&view, nullptr, 0, expected.data(), &common), 1);
  cholmod_finish(&common);
  EXPECT_EQ(blockOrdering(n, pairs, BlockOrdering::Method::kAmd).order, expected);
}

TEST(BlockOrdering, NoBlocksNoOrder) {
  EXPECT_TRUE(blockOrdering(0, {}).order.empty());
  const BlockOrdering lone = blockOrdering(3, {});
  EXPECT_TRUE(isPermutation(lone.order, 3));
}

INSTANTIATE_TEST_SUITE_P(SimplicialAndSupernodal, RankUpdates,
                         ::testing::Combine(::testing::Values(30, 600), ::testing::Bool(),
                                            ::testing::Values(SparseSolver::Kind::kAuto,
                                                              SparseSolver::Kind::kSimplicial)));

}  // namespace
}  // namespace rrr_graphslam::core
