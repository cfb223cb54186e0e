#include "rrr_graphslam/rrr/clustering.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <unordered_map>

#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::rrr {
namespace {

struct Ordered {
  int low;
  int high;
  int index;
};

std::vector<Ordered> sortByLowEnd(const std::vector<CandidateEnds>& ends) {
  std::vector<Ordered> sorted;
  sorted.reserve(ends.size());
  for (std::size_t k = 0; k < ends.size(); ++k) {
    sorted.push_back({std::min(ends[k].first, ends[k].second),
                      std::max(ends[k].first, ends[k].second), static_cast<int>(k)});
  }
  std::sort(sorted.begin(), sorted.end(), [](const Ordered& a, const Ordered& b) {
    return a.low != b.low ? a.low < b.low : a.index < b.index;
  });
  return sorted;
}

}  // namespace

std::vector<std::vector<int>> clusterCandidates(const std::vector<CandidateEnds>& ends, int gap,
                                                const std::vector<int>& session_of) {
  auto same_session = [&](int a, int b) {
    return session_of.empty() ||
           session_of[static_cast<std::size_t>(a)] == session_of[static_cast<std::size_t>(b)];
  };
  const std::vector<Ordered> sorted = sortByLowEnd(ends);
  core::UnionFind sets(ends.size());
  for (std::size_t a = 0; a < sorted.size(); ++a) {
    for (std::size_t b = a + 1; b < sorted.size() && sorted[b].low - sorted[a].low <= gap; ++b) {
      if (std::abs(sorted[b].high - sorted[a].high) <= gap &&
          same_session(sorted[a].low, sorted[b].low) &&
          same_session(sorted[a].high, sorted[b].high)) {
        sets.unite(static_cast<std::size_t>(sorted[a].index),
                   static_cast<std::size_t>(sorted[b].index));
      }
    }
  }
  std::unordered_map<std::size_t, std::size_t> cluster_of_root;
  std::vector<std::vector<int>> clusters;
  for (std::size_t k = 0; k < ends.size(); ++k) {
    const auto [it, inserted] = cluster_of_root.emplace(sets.find(k), clusters.size());
    if (inserted) clusters.emplace_back();
    clusters[it->second].push_back(static_cast<int>(k));
  }
  return clusters;  // members were visited in index order: sorted, and clusters by first member
}

int deriveClusterGap(const std::vector<CandidateEnds>& ends) {
  constexpr int kMinGap = 2;
  constexpr int kMaxGap = 50;
  if (ends.size() < 2) return kMinGap;
  const std::vector<Ordered> sorted = sortByLowEnd(ends);
  std::vector<int> nearest(sorted.size(), INT_MAX);
  for (std::size_t a = 0; a < sorted.size(); ++a) {
    // Only neighbours within kMaxGap in the low end can matter for the clamped result.
    for (std::size_t b = a + 1; b < sorted.size() && sorted[b].low - sorted[a].low <= kMaxGap;
         ++b) {
      const int d =
          std::max(sorted[b].low - sorted[a].low, std::abs(sorted[b].high - sorted[a].high));
      nearest[a] = std::min(nearest[a], d);
      nearest[b] = std::min(nearest[b], d);
    }
  }
  const std::size_t q = nearest.size() / 4;
  std::nth_element(nearest.begin(), nearest.begin() + static_cast<long>(q), nearest.end());
  const int p25 = nearest[q];
  if (p25 == INT_MAX) return kMaxGap;
  return std::clamp(static_cast<int>(std::lround(2.5 * p25)), kMinGap, kMaxGap);
}

}  // namespace rrr_graphslam::rrr
