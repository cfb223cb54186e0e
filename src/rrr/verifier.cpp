#include "rrr_graphslam/rrr/verifier.h"

#include <stdexcept>

namespace rrr_graphslam::rrr {

std::string toString(Verifier verifier) {
  switch (verifier) {
    case Verifier::kRrr:
      return "rrr";
    case Verifier::kPcm:
      return "pcm";
    case Verifier::kScgp:
      return "scgp";
    case Verifier::kGnc:
      return "gnc";
  }
  return "?";
}

Verifier parseVerifier(const std::string& text) {
  for (Verifier v : {Verifier::kRrr, Verifier::kPcm, Verifier::kScgp, Verifier::kGnc}) {
    if (text == toString(v)) return v;
  }
  throw std::invalid_argument("verifier '" + text + "' is not rrr, pcm, scgp or gnc");
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
