#include "rrr_graphslam/rrr/online_verifier.h"

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <utility>

namespace rrr_graphslam::rrr {

OnlineVerifier::OnlineVerifier(VerificationGraph& graph, const VerifierChoice& choice,
                               const RrrParams& params, int cluster_gap)
    : graph_(graph), choice_(choice), params_(params), open_(graph, cluster_gap) {
  if (choice.verifier == Verifier::kRrr) {
    throw std::invalid_argument("OnlineVerifier: RRR decides online through IncrementalRrr");
  }
  if (cluster_gap <= 0) throw std::invalid_argument("OnlineVerifier: cluster_gap must be > 0");
  validate(choice_);
  params_.cluster_gap = cluster_gap;  // SCGP's time clusters are the online ones
}

bool OnlineVerifier::addCandidate(int candidate) {
  const auto n = static_cast<std::size_t>(graph_.numCandidates());
  cluster_of_.resize(n, -1);
  verdicts_.resize(n, Verdict::kPending);
  reasons_.resize(n);
  const LoopCandidate& c = graph_.candidate(candidate);
  bool closed = advanceTo(std::max(c.from, c.to));
  if (open_.add(candidate)) closed = advanceTo(open_.currentNode()) || closed;
  return closed;
}

bool OnlineVerifier::advanceTo(int node) { return closeAndDecide(open_.advanceTo(node)); }

bool OnlineVerifier::closeJoining(int session_first) {
  return closeAndDecide(open_.closeJoining(session_first));
}

bool OnlineVerifier::closeAndDecide(const std::vector<std::vector<int>>& closed) {
  if (closed.empty()) return false;
  close(closed);
  if (!defer_) decideClosed();
  return true;
}

void OnlineVerifier::finish() {
  close(open_.closeAll());
  decideClosed();
}

void OnlineVerifier::close(const std::vector<std::vector<int>>& clusters) {
  for (const std::vector<int>& members : clusters) {
    for (int k : members) {
      cluster_of_[static_cast<std::size_t>(k)] = clusters_;
      reasons_[static_cast<std::size_t>(k)] = toString(choice_.verifier) +
                                              ": cluster closed, not decided yet (a replay is "
                                              "decided at its end)";
    }
    closed_.insert(closed_.end(), members.begin(), members.end());
    ++clusters_;
  }
  std::sort(closed_.begin(), closed_.end());
}

void OnlineVerifier::decideClosed() {
  // Odometry alone: mapEstimate() follows it. A raised cancel flag: the graph is thrown away.
  const std::atomic<bool>* cancel = graph_.optimizer().cancelFlag();
  if (closed_.empty() || (cancel != nullptr && cancel->load())) return;
  VerificationGraph closed(graph_.poseGraphWith(closed_), params_.optimizer);
  closed.optimizer().setCancelFlag(cancel);
  // Nodes a localization run holds where they are stay held (OnlineRrr::fixNodes).
  for (int k = 0; k < graph_.numNodes(); ++k) {
    if (graph_.optimizer().isFixed(k)) closed.optimizer().setFixed(k, true);
  }
  VerifierDecisions decided;
  if (choice_.verifier == Verifier::kPcm) {
    const PcmParams pcm = pcmParamsFor(params_);
    const std::optional<core::AdjacencyMatrix> consistent =
        pcm_pairs_.consistency(graph_, closed_, pcm, cancel);
    if (!consistent) return;
    decided = decidePcm(closed, *consistent, pcm);
  } else {
    decided = decideBatch(closed, choice_, params_);
  }
  for (std::size_t i = 0; i < closed_.size(); ++i) {
    const auto k = static_cast<std::size_t>(closed_[i]);
    verdicts_[k] = decided.verdicts[i];
    reasons_[k] = decided.reasons[i];
  }
  optimizations_ += decided.summary.optimizations;
  solution_ = closed.optimizer().poses();
}

Verdict OnlineVerifier::verdict(int candidate) const {
  const auto k = static_cast<std::size_t>(candidate);
  return k < verdicts_.size() ? verdicts_[k] : Verdict::kPending;
}

int OnlineVerifier::clusterOf(int candidate) const {
  const auto k = static_cast<std::size_t>(candidate);
  return k < cluster_of_.size() ? cluster_of_[k] : -1;
}

std::string OnlineVerifier::reason(int candidate) const {
  const auto k = static_cast<std::size_t>(candidate);
  return k < reasons_.size() && !reasons_[k].empty()
             ? reasons_[k]
             : toString(choice_.verifier) + ": its time cluster is open";
}

std::vector<core::Pose2> OnlineVerifier::mapEstimate() const {
  std::vector<core::Pose2> poses = solution_;
  graph_.extendByOdometry(poses);
  return poses;
}

}  // namespace rrr_graphslam::rrr
