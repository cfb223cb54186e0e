#include "rrr_graphslam/rrr/verifier_choice.h"

#include <stdexcept>
#include <string>

namespace rrr_graphslam::rrr {

void validate(const VerifierChoice& choice) {
  if (!(choice.scgp_ratio >= 1.0)) {
    throw std::invalid_argument("scgp_ratio = " + std::to_string(choice.scgp_ratio) +
                                " is out of range: must be at least 1");
  }
}

PcmParams pcmParamsFor(const RrrParams& params) {
  PcmParams pcm;
  pcm.alpha = params.alpha;
  return pcm;
}

VerifierDecisions decideBatch(VerificationGraph& graph, const VerifierChoice& choice,
                              const RrrParams& params, const ProgressFunction& progress) {
  validate(choice);
  switch (choice.verifier) {
    case Verifier::kPcm:
      return decidePcm(graph, pcmParamsFor(params));
    case Verifier::kScgp: {
      ScgpParams scgp;
      scgp.ratio = choice.scgp_ratio;
      scgp.cluster_gap = params.cluster_gap;
      return decideScgp(graph, scgp);
    }
    case Verifier::kGnc: {
      GncParams gnc;
      gnc.alpha = params.alpha;
      gnc.loss = choice.gnc_loss;
      return decideGnc(graph, gnc);
    }
    case Verifier::kRrr:
      break;
  }
  VerifierDecisions out;
  out.summary = runBatchRrr(graph, params, out.verdicts, out.cluster_of, progress, &out.reasons);
  return out;
}

}  // namespace rrr_graphslam::rrr
