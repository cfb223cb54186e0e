// Batch RRR over a whole graph, and the verdict table both modes hand to their callers.

#include <chrono>

#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {

std::vector<CandidateEnds> candidateEnds(const VerificationGraph& graph) {
  std::vector<CandidateEnds> ends;
  ends.reserve(static_cast<std::size_t>(graph.numCandidates()));
  for (int k = 0; k < graph.numCandidates(); ++k)
    ends.emplace_back(graph.candidate(k).from, graph.candidate(k).to);
  return ends;
}

int clusterGapFor(const RrrParams& params, const std::vector<CandidateEnds>& ends) {
  return params.cluster_gap > 0 ? params.cluster_gap : deriveClusterGap(ends);
}

void collectVerdicts(const Rrr& rrr, std::chrono::steady_clock::time_point start,
                     std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                     RrrSummary& summary, std::vector<std::string>* reasons) {
  const auto n = static_cast<std::size_t>(summary.candidates);
  verdicts.assign(n, Verdict::kPending);
  cluster_of.assign(n, -1);
  if (reasons != nullptr) reasons->assign(n, std::string());
  summary.clusters = rrr.numClusters();
  for (std::size_t k = 0; k < n; ++k) {
    verdicts[k] = rrr.verdict(static_cast<int>(k));
    cluster_of[k] = rrr.clusterOf(static_cast<int>(k));
    if (reasons != nullptr) (*reasons)[k] = rrr.reason(static_cast<int>(k));
    (verdicts[k] == Verdict::kAccepted ? summary.accepted : summary.rejected)++;
  }
  summary.optimizations = rrr.optimizations();
  summary.steps = rrr.stepCosts();
  summary.time_sec =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RrrSummary runBatchRrr(VerificationGraph& graph, const RrrParams& params,
                       std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                       const ProgressFunction& progress, std::vector<std::string>* reasons) {
  const auto start = std::chrono::steady_clock::now();
  RrrSummary summary;
  summary.candidates = graph.numCandidates();
  const std::vector<CandidateEnds> ends = candidateEnds(graph);
  summary.cluster_gap = clusterGapFor(params, ends);
  std::vector<int> session_of(static_cast<std::size_t>(graph.numNodes()));
  for (int n = 0; n < graph.numNodes(); ++n) {
    session_of[static_cast<std::size_t>(n)] = graph.chain().session(n);
  }
  const auto clusters = clusterCandidates(ends, summary.cluster_gap, session_of);

  Rrr rrr(graph, params);
  rrr.setProgress(progress);
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    rrr.addCluster(clusters[c]);
    if (progress && (c % 64 == 0 || c + 1 == clusters.size())) {
      progress("intra", static_cast<int>(c + 1), static_cast<int>(clusters.size()));
    }
  }
  rrr.decideFromScratch();

  collectVerdicts(rrr, start, verdicts, cluster_of, summary, reasons);
  return summary;
}

}  // namespace rrr_graphslam::rrr
