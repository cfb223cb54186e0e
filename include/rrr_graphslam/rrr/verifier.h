#pragma once
// The loop-closure verifiers rrr_offline can run on the same candidates, beside RRR: each takes
// the VerificationGraph (odometry trusted, candidates switched off) and returns one verdict per
// candidate, written to the same DECISIONS.tsv and scored by the same evaluation.
//   rrr   Latif, Cadena, Neira, IJRR 2013 (rrr.h, incremental_rrr.h): the product's verifier.
//   pcm   pairwise consistency maximization (Mangelson et al., ICRA 2018): pcm.h.
//   scgp  Olson's single-cluster graph partitioning, per time cluster: scgp.h.
//   gnc   graduated non-convexity (Yang, Antonante, Tzoumas, Carlone, RA-L 2020): gnc.h.

#include <chrono>
#include <string>
#include <vector>

#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

enum class Verifier { kRrr, kPcm, kScgp, kGnc };

inline core::Choices<Verifier> choices(Verifier /*tag*/) {
  return {{Verifier::kRrr, "rrr"},
          {Verifier::kPcm, "pcm"},
          {Verifier::kScgp, "scgp"},
          {Verifier::kGnc, "gnc"}};
}

/// "rrr", "pcm", "scgp", "gnc".
std::string toString(Verifier verifier);
/// Parses one of those names; std::invalid_argument naming the choices otherwise.
Verifier parseVerifier(const std::string& text);

/// What a verifier decided: per candidate (VerificationGraph order) its verdict, its cluster (-1
/// when the verifier forms none around it) and the reason, and the counts. The graph's optimizer
/// is left with the accepted candidates switched on, at their optimum.
struct VerifierDecisions {
  std::vector<Verdict> verdicts;
  std::vector<int> cluster_of;
  std::vector<std::string> reasons;
  RrrSummary summary;
};

/// The end every verifier shares: the `accepted` candidates switched on (all others off) and
/// optimized, and `out.summary`'s candidates, accepted, rejected, one more optimization and the
/// time since `start`.
void finishDecisions(VerificationGraph& graph, const std::vector<int>& accepted,
                     std::chrono::steady_clock::time_point start, VerifierDecisions& out);

}  // namespace rrr_graphslam::rrr
