#include "rrr_graphslam/rrr/incremental_rrr.h"

#include <algorithm>
#include <chrono>
#include <numeric>

#include "rrr_graphslam/rrr/clustering.h"

namespace rrr_graphslam::rrr {
namespace {

int newestEnd(const LoopCandidate& c) { return std::max(c.from, c.to); }
int oldestEnd(const LoopCandidate& c) { return std::min(c.from, c.to); }

}  // namespace

IncrementalRrr::IncrementalRrr(VerificationGraph& graph, const RrrParams& params, int cluster_gap)
    : graph_(graph), rrr_(graph, params), gap_(cluster_gap) {}

bool IncrementalRrr::addCandidate(int candidate) {
  const LoopCandidate& c = graph_.candidate(candidate);
  const int newest = newestEnd(c);
  bool closed = advanceTo(newest);
  // Join (and merge) every open cluster with a member whose both ends are within the gap.
  OpenCluster joined;
  joined.members.push_back(candidate);
  joined.newest = newest;
  std::vector<OpenCluster> still_open;
  for (OpenCluster& open : open_) {
    const bool related = std::any_of(open.members.begin(), open.members.end(), [&](int m) {
      const LoopCandidate& o = graph_.candidate(m);
      return std::abs(oldestEnd(o) - oldestEnd(c)) <= gap_ &&
             std::abs(newestEnd(o) - newest) <= gap_;
    });
    if (related) {
      joined.members.insert(joined.members.end(), open.members.begin(), open.members.end());
      joined.newest = std::max(joined.newest, open.newest);
    } else {
      still_open.push_back(std::move(open));
    }
  }
  std::sort(joined.members.begin(), joined.members.end());
  const bool behind = current_node_ > joined.newest + gap_;
  still_open.push_back(std::move(joined));
  open_.swap(still_open);
  if (behind) closed = advanceTo(current_node_) || closed;
  return closed;
}

bool IncrementalRrr::advanceTo(int node) {
  current_node_ = std::max(current_node_, node);
  bool closed = false;
  std::vector<OpenCluster> still_open;
  for (OpenCluster& open : open_) {
    if (current_node_ > open.newest + gap_) {
      rrr_.addCluster(open.members);
      closed = true;
    } else {
      still_open.push_back(std::move(open));
    }
  }
  open_.swap(still_open);
  if (closed) rrr_.decideIncrementally();
  return closed;
}

void IncrementalRrr::finish() {
  for (const OpenCluster& open : open_) rrr_.addCluster(open.members);
  open_.clear();
  rrr_.decideFromScratch();
}

RrrSummary runIncrementalRrr(VerificationGraph& graph, const RrrParams& params,
                             std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                             const ProgressFunction& progress, std::vector<double>* latencies_sec) {
  const auto start = std::chrono::steady_clock::now();
  RrrSummary summary;
  summary.candidates = graph.numCandidates();
  const std::vector<CandidateEnds> ends = candidateEnds(graph);
  // Offline the gap can be derived from every candidate; a robot sets cluster_gap instead.
  summary.cluster_gap = params.cluster_gap > 0 ? params.cluster_gap : deriveClusterGap(ends);

  std::vector<int> order(static_cast<std::size_t>(graph.numCandidates()));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return newestEnd(graph.candidate(a)) < newestEnd(graph.candidate(b));
  });

  IncrementalRrr incremental(graph, params, summary.cluster_gap);
  if (latencies_sec) latencies_sec->clear();
  for (std::size_t i = 0; i < order.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    incremental.addCandidate(order[i]);
    if (latencies_sec) {
      latencies_sec->push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    if (progress && (i % 256 == 0 || i + 1 == order.size())) {
      progress("incremental", static_cast<int>(i + 1), static_cast<int>(order.size()));
    }
  }
  incremental.finish();

  collectVerdicts(incremental.rrr(), start, verdicts, cluster_of, summary);
  return summary;
}

}  // namespace rrr_graphslam::rrr
