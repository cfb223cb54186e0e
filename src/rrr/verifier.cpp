#include "rrr_graphslam/rrr/verifier.h"

#include <stdexcept>

namespace rrr_graphslam::rrr {

std::string toString(Verifier verifier) { return core::choiceName(verifier); }

Verifier parseVerifier(const std::string& text) {
  return core::parseChoiceOrThrow<Verifier>(text, "verifier");
}

void finishDecisions(VerificationGraph& graph, const std::vector<int>& accepted,
                     std::chrono::steady_clock::time_point start, VerifierDecisions& out) {
  graph.optimize(accepted);
  RrrSummary& summary = out.summary;
  summary.candidates = graph.numCandidates();
  summary.accepted = static_cast<int>(accepted.size());
  summary.rejected = summary.candidates - summary.accepted;
  ++summary.optimizations;
  summary.time_sec =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace rrr_graphslam::rrr
