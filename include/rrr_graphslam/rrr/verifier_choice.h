#pragma once
// Which verifier decides, with its settings: the choice that rrr_offline's and rrr_slam_offline's
// --verifier and the node's parameter `verifier` make, and the one call that decides a whole
// graph in batch with it (verifier.h lists the verifiers).

#include "rrr_graphslam/rrr/gnc.h"
#include "rrr_graphslam/rrr/pcm.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/scgp.h"
#include "rrr_graphslam/rrr/verifier.h"

namespace rrr_graphslam::rrr {

struct VerifierChoice {
  Verifier verifier = Verifier::kRrr;
  /// gnc only: the robust loss.
  GncParams::Loss gnc_loss = GncParams::Loss::kTruncatedLeastSquares;
  /// scgp only: the ratio of the two largest eigenvalues a cluster must reach (>= 1).
  double scgp_ratio = ScgpParams{}.ratio;
};

/// std::invalid_argument naming the setting that is out of range.
void validate(const VerifierChoice& choice);

/// The settings decideBatch gives PCM: RrrParams' alpha.
PcmParams pcmParamsFor(const RrrParams& params);

/// Decides every candidate of `graph` in batch: RRR with `params`; PCM and GNC at its alpha;
/// SCGP with its cluster_gap. The graph's optimizer is left at the accepted candidates' optimum.
VerifierDecisions decideBatch(VerificationGraph& graph, const VerifierChoice& choice,
                              const RrrParams& params, const ProgressFunction& progress = {});

}  // namespace rrr_graphslam::rrr
