#pragma once
// Quantiles of timings for reports and benchmarks.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace rrr_graphslam::core {

/// The q-quantile of sorted, non-empty `values` by the nearest-rank method: the smallest value
/// with at least a fraction q of them at or below it (p99 of fewer than 100 values is the largest).
inline double nearestRank(const std::vector<double>& values, double q) {
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank > 0 ? rank - 1 : 0)];
}

}  // namespace rrr_graphslam::core
