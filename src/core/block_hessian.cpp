#include "rrr_graphslam/core/block_hessian.h"

#include <algorithm>
#include <stdexcept>

namespace rrr_graphslam::core {

void BlockHessian::build(int num_blocks, const std::vector<std::pair<int, int>>& block_pairs) {
  num_blocks_ = num_blocks;
  // Row blocks above the diagonal, per column block, sorted and unique.
  std::vector<std::vector<int>> rows_of_column(static_cast<std::size_t>(num_blocks));
  for (auto [a, b] : block_pairs) {
    if (a == b) continue;
    if (a > b) std::swap(a, b);
    rows_of_column[static_cast<std::size_t>(b)].push_back(a);
  }
  int nonzeros = 0;
  for (auto& rows : rows_of_column) {
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    // Each of the 3 columns holds 3 entries per off-diagonal block plus 1..3 diagonal entries.
    nonzeros += 9 * static_cast<int>(rows.size()) + 6;
  }

  const int n = 3 * num_blocks;
  matrix_.resize(n, n);
  matrix_.resizeNonZeros(nonzeros);
  int* outer = matrix_.outerIndexPtr();
  int* inner = matrix_.innerIndexPtr();
  int k = 0;
  for (int cb = 0; cb < num_blocks; ++cb) {
    for (int j = 0; j < 3; ++j) {
      outer[3 * cb + j] = k;
      for (int rb : rows_of_column[static_cast<std::size_t>(cb)]) {
        for (int i = 0; i < 3; ++i) inner[k++] = 3 * rb + i;
      }
      for (int i = 0; i <= j; ++i) inner[k++] = 3 * cb + i;
    }
  }
  outer[n] = k;
  setZero();

  diagonal_slots_.resize(static_cast<std::size_t>(num_blocks));
  for (int b = 0; b < num_blocks; ++b) {
    const int o = 3 * b;
    diagonal_slots_[static_cast<std::size_t>(b)] = {slot(o, o),         slot(o, o + 1),
                                                    slot(o, o + 2),     slot(o + 1, o + 1),
                                                    slot(o + 1, o + 2), slot(o + 2, o + 2)};
  }
}

int BlockHessian::slot(int row, int col) const {
  const int* inner = matrix_.innerIndexPtr();
  const int* begin = inner + matrix_.outerIndexPtr()[col];
  const int* end = inner + matrix_.outerIndexPtr()[col + 1];
  const int* it = std::lower_bound(begin, end, row);
  if (it == end || *it != row) throw std::logic_error("BlockHessian: entry not in the pattern");
  return static_cast<int>(it - inner);
}

BlockHessian::OffDiagonalSlots BlockHessian::offDiagonalSlots(int row_block, int col_block) const {
  OffDiagonalSlots s;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) s[3 * r + c] = slot(3 * row_block + r, 3 * col_block + c);
  }
  return s;
}

Eigen::VectorXd BlockHessian::diagonal() const {
  Eigen::VectorXd d(3 * num_blocks_);
  const double* v = matrix_.valuePtr();
  for (int b = 0; b < num_blocks_; ++b) {
    const DiagonalSlots& s = diagonal_slots_[static_cast<std::size_t>(b)];
    d.segment<3>(3 * b) << v[s[0]], v[s[3]], v[s[5]];
  }
  return d;
}

void BlockHessian::setDiagonal(const Eigen::VectorXd& diagonal) {
  double* v = values();
  for (int b = 0; b < num_blocks_; ++b) {
    const DiagonalSlots& s = diagonal_slots_[static_cast<std::size_t>(b)];
    v[s[0]] = diagonal(3 * b);
    v[s[3]] = diagonal(3 * b + 1);
    v[s[5]] = diagonal(3 * b + 2);
  }
}

}  // namespace rrr_graphslam::core
