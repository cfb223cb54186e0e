// BlockHessian's compressed pattern and slots against a dense brute-force assembly.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "rrr_graphslam/core/block_hessian.h"

namespace rrr_graphslam::core {
namespace {

TEST(BlockHessian, AssemblyMatchesDenseMatrix) {
  std::mt19937 rng(5);
  const int blocks = 12;
  std::uniform_int_distribution<int> pick(0, blocks - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<std::pair<int, int>> pairs;
  for (int k = 0; k < 30; ++k) {
    const int a = pick(rng), b = pick(rng);
    if (a != b) pairs.emplace_back(a, b);
  }
  pairs.push_back(pairs.front());  // duplicates are allowed
  BlockHessian h;
  h.build(blocks, pairs);

  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * blocks, 3 * blocks);
  for (auto [a, b] : pairs) {
    const int r = std::min(a, b), c = std::max(a, b);
    const Eigen::Matrix3d M =
        Eigen::Matrix3d::NullaryExpr([&](Eigen::Index, Eigen::Index) { return value(rng); });
    h.addOffDiagonal(h.offDiagonalSlots(r, c), M);
    dense.block<3, 3>(3 * r, 3 * c) += M;
  }
  for (int b = 0; b < blocks; ++b) {
    Eigen::Matrix3d M =
        Eigen::Matrix3d::NullaryExpr([&](Eigen::Index, Eigen::Index) { return value(rng); });
    M = (M + M.transpose()).eval();
    h.addDiagonal(b, M);
    dense.block<3, 3>(3 * b, 3 * b) += M.triangularView<Eigen::Upper>().toDenseMatrix();
  }
  EXPECT_LT((h.diagonal() - dense.diagonal()).norm(), 1e-12);
  h.setDiagonal(h.diagonal().array() + 0.5);
  dense.diagonal().array() += 0.5;
  const Eigen::MatrixXd assembled = Eigen::MatrixXd(h.matrix());
  EXPECT_LT((assembled - dense).norm(), 1e-12);
  // The pattern holds only what was asked for: diagonal blocks' upper triangles + pairs.
  int expected_nonzeros = 6 * blocks;
  std::set<std::pair<int, int>> unique;
  for (auto [a, b] : pairs) unique.emplace(std::min(a, b), std::max(a, b));
  expected_nonzeros += 9 * static_cast<int>(unique.size());
  EXPECT_EQ(h.matrix().nonZeros(), expected_nonzeros);
}

}  // namespace
}  // namespace rrr_graphslam::core
