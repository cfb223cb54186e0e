#include "rrr_graphslam/rrr/online_verifier.h"

#include <algorithm>
#include <cstddef>
#include <iterator>
#include <stdexcept>
#include <utility>

#include "rrr_graphslam/core/chi2.h"

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

bool OnlineVerifier::advanceTo(int node) {
  const std::vector<std::vector<int>> closed = open_.advanceTo(node);
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
  if (closed_.empty()) return;  // odometry alone: mapEstimate() follows it
  VerificationGraph closed(graph_.poseGraphWith(closed_), params_.optimizer);
  // Nodes a localization run holds where they are stay held (OnlineRrr::fixNodes).
  for (int k = 0; k < graph_.numNodes(); ++k) {
    if (graph_.optimizer().isFixed(k)) closed.optimizer().setFixed(k, true);
  }
  const VerifierDecisions decided = choice_.verifier == Verifier::kPcm
                                        ? decidePcm(closed, pcmConsistency(), pcmParamsFor(params_))
                                        : decideBatch(closed, choice_, params_);
  for (std::size_t i = 0; i < closed_.size(); ++i) {
    const auto k = static_cast<std::size_t>(closed_[i]);
    verdicts_[k] = decided.verdicts[i];
    reasons_[k] = decided.reasons[i];
  }
  optimizations_ += decided.summary.optimizations;
  solution_ = closed.optimizer().poses();
}

core::AdjacencyMatrix OnlineVerifier::pcmConsistency() {
  const PcmParams pcm = pcmParamsFor(params_);
  const double threshold = core::chi2Quantile(pcm.alpha, 3);
  std::vector<int> fresh;
  std::set_difference(closed_.begin(), closed_.end(), pcm_tested_.begin(), pcm_tested_.end(),
                      std::back_inserter(fresh));
  std::vector<std::pair<int, int>> pairs;  // (i, j), i < j: as decidePcm tests them
  for (std::size_t f = 0; f < fresh.size(); ++f) {
    for (int t : pcm_tested_) pairs.emplace_back(std::min(fresh[f], t), std::max(fresh[f], t));
    for (std::size_t g = f + 1; g < fresh.size(); ++g) pairs.emplace_back(fresh[f], fresh[g]);
  }
  std::vector<char> consistent(pairs.size(), 0);
  const auto n = static_cast<std::ptrdiff_t>(pairs.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(pcm.threads) if (n > 4096)
  for (std::ptrdiff_t p = 0; p < n; ++p) {
    const auto& [i, j] = pairs[static_cast<std::size_t>(p)];
    consistent[static_cast<std::size_t>(p)] = pairwiseConsistent(graph_, i, j, threshold) ? 1 : 0;
  }
  pcm_partners_.resize(static_cast<std::size_t>(graph_.numCandidates()));
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (!consistent[p]) continue;
    pcm_partners_[static_cast<std::size_t>(pairs[p].first)].push_back(pairs[p].second);
    pcm_partners_[static_cast<std::size_t>(pairs[p].second)].push_back(pairs[p].first);
  }
  pcm_tested_ = closed_;

  std::vector<int> vertex(static_cast<std::size_t>(graph_.numCandidates()), -1);
  for (std::size_t v = 0; v < closed_.size(); ++v) {
    vertex[static_cast<std::size_t>(closed_[v])] = static_cast<int>(v);
  }
  core::AdjacencyMatrix adjacency(static_cast<int>(closed_.size()));
  for (int i : closed_) {
    for (int j : pcm_partners_[static_cast<std::size_t>(i)]) {
      if (i < j)
        adjacency.connect(vertex[static_cast<std::size_t>(i)], vertex[static_cast<std::size_t>(j)]);
    }
  }
  return adjacency;
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
