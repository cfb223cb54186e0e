#include "rrr_graphslam/rrr/pcm_pair_cache.h"

#include <algorithm>
#include <cstddef>
#include <iterator>
#include <stdexcept>
#include <utility>

#include "rrr_graphslam/core/chi2.h"

namespace rrr_graphslam::rrr {

std::optional<core::AdjacencyMatrix> PcmPairCache::consistency(const VerificationGraph& graph,
                                                               const std::vector<int>& candidates,
                                                               const PcmParams& params,
                                                               const std::atomic<bool>* cancel) {
  auto cancelled = [&] { return cancel != nullptr && cancel->load(); };
  if (!std::includes(candidates.begin(), candidates.end(), tested_.begin(), tested_.end())) {
    throw std::invalid_argument("PcmPairCache: a candidate tested before is missing");
  }
  const double threshold = core::chi2Quantile(params.alpha, 3);
  std::vector<int> fresh;
  std::set_difference(candidates.begin(), candidates.end(), tested_.begin(), tested_.end(),
                      std::back_inserter(fresh));
  std::vector<std::pair<int, int>> pairs;  // (i, j), i < j
  for (std::size_t f = 0; f < fresh.size(); ++f) {
    for (int t : tested_) pairs.emplace_back(std::min(fresh[f], t), std::max(fresh[f], t));
    for (std::size_t g = f + 1; g < fresh.size(); ++g) pairs.emplace_back(fresh[f], fresh[g]);
  }
  std::vector<char> consistent(pairs.size(), 0);
  const auto n = static_cast<std::ptrdiff_t>(pairs.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(params.threads) if (n > 4096)
  for (std::ptrdiff_t p = 0; p < n; ++p) {
    if (cancelled()) continue;
    const auto& [i, j] = pairs[static_cast<std::size_t>(p)];
    consistent[static_cast<std::size_t>(p)] = pairwiseConsistent(graph, i, j, threshold) ? 1 : 0;
  }
  if (cancelled()) return std::nullopt;
  partners_.resize(static_cast<std::size_t>(graph.numCandidates()));
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (!consistent[p]) continue;
    partners_[static_cast<std::size_t>(pairs[p].first)].push_back(pairs[p].second);
    partners_[static_cast<std::size_t>(pairs[p].second)].push_back(pairs[p].first);
  }
  tested_ = candidates;

  std::vector<int> vertex(static_cast<std::size_t>(graph.numCandidates()), -1);
  for (std::size_t v = 0; v < candidates.size(); ++v) {
    vertex[static_cast<std::size_t>(candidates[v])] = static_cast<int>(v);
  }
  core::AdjacencyMatrix adjacency(static_cast<int>(candidates.size()));
  for (int i : candidates) {
    for (int j : partners_[static_cast<std::size_t>(i)]) {
      if (i < j) {
        adjacency.connect(vertex[static_cast<std::size_t>(i)], vertex[static_cast<std::size_t>(j)]);
      }
    }
  }
  return adjacency;
}

}  // namespace rrr_graphslam::rrr
