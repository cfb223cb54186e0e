#include "rrr_graphslam/rrr/pcm.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/max_clique.h"
#include "rrr_graphslam/rrr/pairwise_consistency.h"

namespace rrr_graphslam::rrr {

namespace {

void validate(const PcmParams& params) {
  if (!(params.alpha > 0.0 && params.alpha < 1.0)) {
    throw std::invalid_argument("pcm: alpha = " + std::to_string(params.alpha) +
                                " is out of range: must be in (0, 1)");
  }
  if (params.max_branches < 1) throw std::invalid_argument("pcm: max_branches must be >= 1");
  if (params.threads < 1) throw std::invalid_argument("pcm: threads must be >= 1");
  if (params.max_exact_candidates < 0) {
    throw std::invalid_argument("pcm: max_exact_candidates must be >= 0");
  }
}

}  // namespace

bool pairwiseConsistent(const VerificationGraph& graph, int i, int j, double threshold) {
  const std::optional<double> d2 = pairwiseCycleChi2(graph, i, j);
  return !d2 || *d2 < threshold;
}

VerifierDecisions decidePcm(VerificationGraph& graph, const PcmParams& params) {
  validate(params);
  const auto start = std::chrono::steady_clock::now();
  const int m = graph.numCandidates();
  const double threshold = core::chi2Quantile(params.alpha, 3);
  // 1. Consistency graph.
  // Rows tested in parallel (the tests only read the graph), joined in order.
  std::vector<std::vector<int>> partners(static_cast<std::size_t>(m));
#pragma omp parallel for schedule(dynamic, 16) num_threads(params.threads) if (m > 64)
  for (int i = 0; i < m; ++i) {
    for (int j = i + 1; j < m; ++j) {
      if (pairwiseConsistent(graph, i, j, threshold)) {
        partners[static_cast<std::size_t>(i)].push_back(j);
      }
    }
  }
  core::AdjacencyMatrix consistent(m);
  for (int i = 0; i < m; ++i) {
    for (int j : partners[static_cast<std::size_t>(i)]) consistent.connect(i, j);
  }
  VerifierDecisions out = decidePcm(graph, consistent, params);
  out.summary.time_sec =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

VerifierDecisions decidePcm(VerificationGraph& graph, const core::AdjacencyMatrix& consistent,
                            const PcmParams& params) {
  validate(params);
  const auto start = std::chrono::steady_clock::now();
  const int m = graph.numCandidates();
  if (consistent.size() != m) {
    throw std::invalid_argument("pcm: the consistency graph has " +
                                std::to_string(consistent.size()) + " vertices for " +
                                std::to_string(m) + " candidates");
  }
  // 2. Maximum clique.
  const bool exact = m <= params.max_exact_candidates;
  const std::vector<int> clique = exact ? core::maximumClique(consistent, {}, params.max_branches)
                                        : core::heuristicMaximumClique(consistent);

  // 3. Verdicts.
  VerifierDecisions out;
  out.verdicts.assign(static_cast<std::size_t>(m), Verdict::kRejected);
  out.cluster_of.assign(static_cast<std::size_t>(m), -1);
  out.reasons.resize(static_cast<std::size_t>(m));
  const std::string size = std::to_string(clique.size());
  const std::string kind = exact ? "maximum" : "largest found (heuristic)";
  for (int k = 0; k < m; ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (std::binary_search(clique.begin(), clique.end(), k)) {
      out.verdicts[i] = Verdict::kAccepted;
      out.cluster_of[i] = 0;
      out.reasons[i] = "pcm: in the " + kind + " pairwise-consistent set (" + size + " candidates)";
    } else {
      int with = 0;
      for (int c : clique) with += consistent.connected(k, c) ? 1 : 0;
      out.reasons[i] = "pcm: not in the " + kind + " pairwise-consistent set (consistent with " +
                       std::to_string(with) + " of its " + size + ")";
    }
  }
  out.summary.clusters = clique.empty() ? 0 : 1;
  finishDecisions(graph, clique, start, out);
  return out;
}

}  // namespace rrr_graphslam::rrr
