#pragma once
// A batch verifier (PCM, SCGP or GNC: verifier_choice.h) deciding online. Candidates are grouped
// into time clusters as they arrive (open_clusters.h); each time clusters close, the verifier
// decides every candidate of the closed clusters again from scratch, on the graph as it is then
// with the open clusters' candidates left out, so that the decision at the end of a run equals
// `rrr_offline --verifier` on the same graph with the same --cluster-gap. Its cost is one batch
// decision per closing, which grows with the candidates: for comparing verifiers on replays and
// runs of an hour, not for a robot that runs for days (RRR, IncrementalRrr, is the online decider
// for that). PCM keeps the pairs it tested (pcm_pair_cache.h), so each closing tests only the new
// candidates' pairs; a graph rebuilt by lifelong trimming starts a new cache. A candidate's cluster
// is its time cluster (rrr_offline --verifier writes the verifier's own: PCM's clique 0 or -1).

#include <string>
#include <vector>

#include "rrr_graphslam/rrr/online_decider.h"
#include "rrr_graphslam/rrr/open_clusters.h"
#include "rrr_graphslam/rrr/pcm_pair_cache.h"

namespace rrr_graphslam::rrr {

class OnlineVerifier final : public OnlineDecider {
 public:
  /// `choice.verifier` must not be RRR (std::invalid_argument); cluster_gap > 0.
  OnlineVerifier(VerificationGraph& graph, const VerifierChoice& choice, const RrrParams& params,
                 int cluster_gap);

  bool addCandidate(int candidate) override;
  bool advanceTo(int node) override;
  bool closeJoining(int session_first) override;
  void finish() override;
  void endRun() override {}
  void finishReplayKeepingOpen() override { decideClosed(); }
  void deferDecisions(bool defer) override { defer_ = defer; }
  void decideClosedFromScratch() override { decideClosed(); }

  Verdict verdict(int candidate) const override;
  int clusterOf(int candidate) const override;
  std::string reason(int candidate) const override;
  std::vector<core::Pose2> mapEstimate() const override;
  int numClusters() const override { return clusters_; }
  int numOpenClusters() const override { return open_.size(); }
  int optimizations() const override { return optimizations_; }

 private:
  /// Numbers the clusters that closed and adds their candidates to the decided ones.
  void close(const std::vector<std::vector<int>>& clusters);
  /// close(), then the decision unless deferred; false if nothing closed.
  bool closeAndDecide(const std::vector<std::vector<int>>& closed);
  /// The verifier on the odometry, the marginal constraints and the closed clusters' candidates.
  void decideClosed();

  VerificationGraph& graph_;
  VerifierChoice choice_;
  RrrParams params_;
  OpenClusters open_;
  bool defer_ = false;
  int clusters_ = 0;
  int optimizations_ = 0;
  std::vector<int> closed_;  ///< candidates of the closed clusters, ascending
  // Per candidate (grown as they arrive): its time cluster (-1 while open), the last decision.
  std::vector<int> cluster_of_;
  std::vector<Verdict> verdicts_;
  std::vector<std::string> reasons_;
  std::vector<core::Pose2> solution_;  ///< the last decision's poses, of the nodes it had
  PcmPairCache pcm_pairs_;             ///< PCM: the pairs tested by earlier decisions
};

}  // namespace rrr_graphslam::rrr
