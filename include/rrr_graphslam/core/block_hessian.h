#pragma once
// The sparse normal matrix H of an SE(2) problem as 3x3 blocks, stored as the upper triangle of
// a compressed column matrix. The pattern is built once from the block pairs that constraints
// couple; each constraint then gets the positions of its entries in the value array, so an
// iteration assembles H by plain additions (no triplets, no sorting, no searching).

#include <array>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/sparse_solver.h"

namespace rrr_graphslam::core {

class BlockHessian {
 public:
  /// Value positions of one 3x3 off-diagonal block (all 9, row-major in the block's own terms).
  using OffDiagonalSlots = std::array<int, 9>;
  /// Value positions of one diagonal block's upper triangle: (0,0) (0,1) (0,2) (1,1) (1,2) (2,2).
  using DiagonalSlots = std::array<int, 6>;

  /// Builds the pattern of `num_blocks` diagonal blocks plus the given (row, col) block pairs
  /// (any order; duplicates allowed).
  void build(int num_blocks, const std::vector<std::pair<int, int>>& block_pairs);

  int numBlocks() const { return num_blocks_; }
  const SparseSolver::Matrix& matrix() const { return matrix_; }
  void setZero() { std::fill(values(), values() + matrix_.nonZeros(), 0.0); }

  const DiagonalSlots& diagonalSlots(int block) const { return diagonal_slots_[block]; }
  /// Slots of block (row, col) with row < col. Only valid for pairs passed to build().
  OffDiagonalSlots offDiagonalSlots(int row_block, int col_block) const;

  /// H(b, b) += M (M symmetric; only its upper triangle is read).
  void addDiagonal(int block, const Eigen::Matrix3d& M) {
    const DiagonalSlots& s = diagonal_slots_[block];
    double* v = values();
    v[s[0]] += M(0, 0);
    v[s[1]] += M(0, 1);
    v[s[2]] += M(0, 2);
    v[s[3]] += M(1, 1);
    v[s[4]] += M(1, 2);
    v[s[5]] += M(2, 2);
  }
  /// H(row, col) += M for the block whose slots are `s` (row < col).
  void addOffDiagonal(const OffDiagonalSlots& s, const Eigen::Matrix3d& M) {
    double* v = values();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) v[s[3 * r + c]] += M(r, c);
    }
  }
  /// The scalar diagonal of H, and writing it back (Levenberg-Marquardt damping).
  Eigen::VectorXd diagonal() const;
  void setDiagonal(const Eigen::VectorXd& diagonal);

 private:
  double* values() { return matrix_.valuePtr(); }
  int slot(int row, int col) const;

  int num_blocks_ = 0;
  SparseSolver::Matrix matrix_;
  std::vector<DiagonalSlots> diagonal_slots_;
};

}  // namespace rrr_graphslam::core
