#pragma once
// PCM's pairwise consistency tests kept across decisions of a growing graph (OnlineVerifier):
// the test of two candidates depends only on them and on the odometry between their ends
// (pairwiseCycleChi2), neither of which changes as nodes and candidates are added, so each
// decision tests only the pairs with a candidate not seen before.

#include <atomic>
#include <optional>
#include <vector>

#include "rrr_graphslam/core/max_clique.h"
#include "rrr_graphslam/rrr/pcm.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

class PcmPairCache {
 public:
  /// PCM's consistency graph over `candidates` (ascending candidate indices of `graph`; vertex v:
  /// candidates[v]), each pair tested as decidePcm tests it (lower index first). `graph` must be
  /// the same growing graph at every call and `candidates` must hold every candidate of the
  /// previous call. Empty, and nothing kept of this call, once `*cancel` is raised.
  std::optional<core::AdjacencyMatrix> consistency(const VerificationGraph& graph,
                                                   const std::vector<int>& candidates,
                                                   const PcmParams& params,
                                                   const std::atomic<bool>* cancel = nullptr);

 private:
  std::vector<int> tested_;                 ///< candidates whose pairs are tested, ascending
  std::vector<std::vector<int>> partners_;  ///< consistent partners among them, by candidate
};

}  // namespace rrr_graphslam::rrr
