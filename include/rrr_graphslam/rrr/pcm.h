#pragma once
// Pairwise consistency maximization (Mangelson, Dominic, Eustice, Vasudevan, "Pairwise
// Consistency Maximization for Robust Multi-robot Map Merging", ICRA 2018), as a verifier beside
// RRR (verifier.h):
//   1. Consistency graph: one vertex per loop candidate; two candidates are joined when the cycle
//      they close with the odometry between their ends passes the chi-square test
//      (pairwiseCycleChi2 of pairwise_consistency.h, the test RRR splits its clusters with), or
//      when no odometry joins their ends (nothing to test, as in RRR's split).
//   2. Maximum clique of that graph (core/max_clique.h): the largest set of pairwise consistent
//      candidates. Exact (branch and bound) up to `max_exact_candidates` candidates; above, the
//      greedy heuristic PCM's implementation offers for large graphs (the exact search recolours
//      the candidates at each level: cubic in the clique's size, hours for thousands of loops).
//   3. Accepted: the clique; rejected: every other candidate.
// Every pair is tested: m candidates cost m(m-1)/2 cycle tests.

#include "rrr_graphslam/core/max_clique.h"
#include "rrr_graphslam/rrr/verification_graph.h"
#include "rrr_graphslam/rrr/verifier.h"

namespace rrr_graphslam::rrr {

struct PcmParams {
  /// The pairwise test's confidence: a cycle is consistent below chi2(alpha, 3 dof).
  double alpha = 0.95;
  /// Up to this many candidates the clique is exact; above, heuristic.
  int max_exact_candidates = 300;
  /// Branch steps of the exact search before it returns the largest clique found.
  long max_branches = 2000000;
  /// Threads of the pairwise tests.
  int threads = 2;
};

/// Step 1 for one pair: whether candidates i < j are consistent, `threshold` being
/// chi2Quantile(alpha, 3).
bool pairwiseConsistent(const VerificationGraph& graph, int i, int j, double threshold);

/// Decides every candidate of `graph` by PCM (steps 1 to 3); leaves the clique switched on and
/// optimized. Throws std::invalid_argument for alpha outside (0, 1), max_branches < 1,
/// threads < 1 or a negative max_exact_candidates.
VerifierDecisions decidePcm(VerificationGraph& graph, const PcmParams& params = {});
/// Steps 2 and 3 on a consistency graph over the graph's candidates (vertex k: candidate k)
/// built with pairwiseConsistent (PcmPairCache keeps the pairs tested before); throws as above,
/// and when the consistency graph has another size than the candidates.
VerifierDecisions decidePcm(VerificationGraph& graph, const core::AdjacencyMatrix& consistent,
                            const PcmParams& params = {});

}  // namespace rrr_graphslam::rrr
