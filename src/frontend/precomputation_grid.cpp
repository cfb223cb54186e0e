#include "rrr_graphslam/frontend/precomputation_grid.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <stdexcept>

namespace rrr_graphslam::frontend {
namespace {

// out[i] = max(in[i .. i + window - 1]) for i in [0, in.size() - window], by a monotonic deque.
void slidingMax(const std::vector<std::uint8_t>& in, int window, std::vector<std::uint8_t>& out) {
  const int n = static_cast<int>(in.size());
  out.assign(static_cast<std::size_t>(n - window + 1), 0);
  std::deque<int> candidates;  // indices with decreasing values
  for (int i = 0; i < n; ++i) {
    while (!candidates.empty() &&
           in[static_cast<std::size_t>(candidates.back())] <= in[static_cast<std::size_t>(i)]) {
      candidates.pop_back();
    }
    candidates.push_back(i);
    if (candidates.front() <= i - window) candidates.pop_front();
    if (i >= window - 1) {
      out[static_cast<std::size_t>(i - window + 1)] =
          in[static_cast<std::size_t>(candidates.front())];
    }
  }
}

}  // namespace

std::uint8_t quantizeProbability(float p) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(p, 0.0F, 1.0F) * 255.0F));
}

PrecomputationGrid::PrecomputationGrid(const MatchGrid& grid, int height)
    : height_(height), unknown_(quantizeProbability(grid.unknown())) {
  if (height < 0 || height > 16) throw std::invalid_argument("precomputation height out of range");
  const int w = 1 << height;
  offset_ = w - 1;
  width_ = grid.width() + offset_;
  rows_ = grid.height() + offset_;
  // Rows: P_row(i, y) = max M(x .. x + w - 1, y) for x = i - offset, read with `unknown` padding.
  const int padded = grid.width() + 2 * offset_;
  std::vector<std::uint8_t> line(static_cast<std::size_t>(padded));
  std::vector<std::uint8_t> maxima;
  std::vector<std::uint8_t> by_rows(static_cast<std::size_t>(width_) *
                                    static_cast<std::size_t>(grid.height()));
  for (int y = 0; y < grid.height(); ++y) {
    for (int k = 0; k < padded; ++k)
      line[static_cast<std::size_t>(k)] = quantizeProbability(grid.at(k - offset_, y));
    slidingMax(line, w, maxima);
    std::copy(maxima.begin(), maxima.end(),
              by_rows.begin() + static_cast<std::ptrdiff_t>(y) * width_);
  }
  // Columns of the row maxima, padded with `unknown` the same way.
  cells_.assign(static_cast<std::size_t>(width_) * static_cast<std::size_t>(rows_), unknown_);
  std::vector<std::uint8_t> column(static_cast<std::size_t>(grid.height() + 2 * offset_));
  for (int i = 0; i < width_; ++i) {
    for (int k = 0; k < static_cast<int>(column.size()); ++k) {
      const int y = k - offset_;
      column[static_cast<std::size_t>(k)] =
          (y >= 0 && y < grid.height())
              ? by_rows[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) +
                        static_cast<std::size_t>(i)]
              : unknown_;
    }
    slidingMax(column, w, maxima);
    for (int j = 0; j < rows_; ++j) {
      cells_[static_cast<std::size_t>(j) * static_cast<std::size_t>(width_) +
             static_cast<std::size_t>(i)] = maxima[static_cast<std::size_t>(j)];
    }
  }
}

PrecomputationGrid PrecomputationGrid::coarser(const PrecomputationGrid& finer) {
  if (finer.height_ >= 16) throw std::invalid_argument("precomputation height out of range");
  const int s = 1 << finer.height_;  // the finer level's block side, and the step between blocks
  PrecomputationGrid out;
  out.height_ = finer.height_ + 1;
  out.unknown_ = finer.unknown_;
  out.offset_ = 2 * s - 1;
  // The match grid's size, and the new level's x (and y) from -offset_ to its last cell.
  const int grid_width = finer.width_ - finer.offset_;
  const int grid_rows = finer.rows_ - finer.offset_;
  out.width_ = grid_width + out.offset_;
  out.rows_ = grid_rows + out.offset_;
  // Rows: R(x, y) = max(P_h(x, y), P_h(x + s, y)) for the finer level's rows y.
  std::vector<std::uint8_t> by_rows(static_cast<std::size_t>(out.width_) *
                                    static_cast<std::size_t>(finer.rows_));
  for (int j = 0; j < finer.rows_; ++j) {
    const int y = j - finer.offset_;
    std::uint8_t* row = by_rows.data() + static_cast<std::ptrdiff_t>(j) * out.width_;
    for (int i = 0; i < out.width_; ++i) {
      const int x = i - out.offset_;
      row[i] = std::max(finer.at(x, y), finer.at(x + s, y));
    }
  }
  // Columns: P_{h+1}(x, y) = max(R(x, y), R(x, y + s)), R read as `unknown` outside its rows.
  auto rowsAt = [&](int i, int y) {
    const int j = y + finer.offset_;
    if (j < 0 || j >= finer.rows_) return out.unknown_;
    return by_rows[static_cast<std::size_t>(j) * static_cast<std::size_t>(out.width_) +
                   static_cast<std::size_t>(i)];
  };
  out.cells_.resize(static_cast<std::size_t>(out.width_) * static_cast<std::size_t>(out.rows_));
  for (int j = 0; j < out.rows_; ++j) {
    const int y = j - out.offset_;
    std::uint8_t* cell = out.cells_.data() + static_cast<std::ptrdiff_t>(j) * out.width_;
    for (int i = 0; i < out.width_; ++i) cell[i] = std::max(rowsAt(i, y), rowsAt(i, y + s));
  }
  return out;
}

PrecomputationGridStack::PrecomputationGridStack(const MatchGrid& grid, int depth)
    : resolution_(grid.resolution()), origin_(grid.origin()) {
  if (depth < 1) throw std::invalid_argument("branch-and-bound depth must be at least 1");
  levels_.reserve(static_cast<std::size_t>(depth));
  levels_.emplace_back(grid, 0);
  for (int h = 1; h < depth; ++h) levels_.push_back(PrecomputationGrid::coarser(levels_.back()));
}

Eigen::Array2i PrecomputationGridStack::cellOf(const Eigen::Vector2d& p) const {
  return {static_cast<int>(std::floor((p.x() - origin_.x()) / resolution_)),
          static_cast<int>(std::floor((p.y() - origin_.y()) / resolution_))};
}

}  // namespace rrr_graphslam::frontend
