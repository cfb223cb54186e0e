#pragma once
// A batch verifier (PCM, SCGP or GNC: verifier_choice.h) deciding online. Candidates are grouped
// into time clusters as they arrive (open_clusters.h); each time clusters close, the verifier
// decides every candidate of the closed clusters again from scratch, on the graph as it is then
// with the open clusters' candidates left out, so that the decision at the end of a run equals
// `rrr_offline --verifier` on the same graph. Its cost is one batch decision per closing, which
// grows with the candidates: for comparing verifiers on replays and runs of an hour, not for a
// robot that runs for days (RRR, IncrementalRrr, is the online decider for that). PCM keeps the
// pairs it tested (a pair's test depends on its two candidates and the odometry between them,
// which never change), so each closing tests only the new candidates' pairs.

#include <string>
#include <vector>

#include "rrr_graphslam/core/max_clique.h"
#include "rrr_graphslam/rrr/online_decider.h"
#include "rrr_graphslam/rrr/open_clusters.h"

namespace rrr_graphslam::rrr {

class OnlineVerifier final : public OnlineDecider {
 public:
  /// `choice.verifier` must not be RRR (std::invalid_argument); cluster_gap > 0.
  OnlineVerifier(VerificationGraph& graph, const VerifierChoice& choice, const RrrParams& params,
                 int cluster_gap);

  bool addCandidate(int candidate) override;
  bool advanceTo(int node) override;
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
  /// The verifier on the odometry, the marginal constraints and the closed clusters' candidates.
  void decideClosed();
  /// PCM's consistency graph over closed_ (vertex i: closed_[i]), testing only the pairs with a
  /// candidate not tested before.
  core::AdjacencyMatrix pcmConsistency();

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
  // PCM: the candidates whose pairs with each other are tested (ascending), and each one's
  // consistent partners among them.
  std::vector<int> pcm_tested_;
  std::vector<std::vector<int>> pcm_partners_;
};

}  // namespace rrr_graphslam::rrr
