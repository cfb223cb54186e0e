#include "rrr_graphslam/rrr/online_decider.h"

#include "rrr_graphslam/rrr/incremental_rrr.h"
#include "rrr_graphslam/rrr/online_verifier.h"

namespace rrr_graphslam::rrr {
namespace {

/// RRR as the online decider: incremental decisions as clusters close (IncrementalRrr).
class IncrementalRrrDecider final : public OnlineDecider {
 public:
  IncrementalRrrDecider(VerificationGraph& graph, const RrrParams& params, int cluster_gap)
      : incremental_(graph, params, cluster_gap) {}

  bool addCandidate(int candidate) override { return incremental_.addCandidate(candidate); }
  bool advanceTo(int node) override { return incremental_.advanceTo(node); }
  bool closeJoining(int session_first) override { return incremental_.closeJoining(session_first); }
  void finish() override { incremental_.finish(); }
  void endRun() override { incremental_.rrr().rejectUnplaced(); }
  void finishReplayKeepingOpen() override { incremental_.finishReplayKeepingOpen(); }
  void deferDecisions(bool defer) override { incremental_.deferDecisions(defer); }
  void decideClosedFromScratch() override { incremental_.decideClosedFromScratch(); }
  void seedPreviousMap(std::vector<core::Pose2> map) override {
    incremental_.rrr().seedPreviousMap(std::move(map));
  }

  Verdict verdict(int candidate) const override { return incremental_.rrr().verdict(candidate); }
  int clusterOf(int candidate) const override { return incremental_.rrr().clusterOf(candidate); }
  std::string reason(int candidate) const override { return incremental_.rrr().reason(candidate); }
  std::vector<core::Pose2> mapEstimate() const override { return incremental_.rrr().mapEstimate(); }
  int numClusters() const override { return incremental_.rrr().numClusters(); }
  int numOpenClusters() const override { return incremental_.numOpenClusters(); }
  int optimizations() const override { return incremental_.rrr().optimizations(); }

 private:
  IncrementalRrr incremental_;
};

}  // namespace

std::unique_ptr<OnlineDecider> makeOnlineDecider(VerificationGraph& graph,
                                                 const VerifierChoice& choice,
                                                 const RrrParams& params, int cluster_gap) {
  if (choice.verifier == Verifier::kRrr) {
    return std::make_unique<IncrementalRrrDecider>(graph, params, cluster_gap);
  }
  return std::make_unique<OnlineVerifier>(graph, choice, params, cluster_gap);
}

}  // namespace rrr_graphslam::rrr
