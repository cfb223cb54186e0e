#include "rrr_graphslam/rrr/rrr.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/consistency.h"

namespace rrr_graphslam::rrr {

std::string toString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted:
      return "accepted";
    case Verdict::kRejected:
      return "rejected";
    case Verdict::kPending:
      return "pending";
  }
  return "unknown";
}

Rrr::Rrr(VerificationGraph& graph, const RrrParams& params)
    : graph_(graph),
      params_(params),
      cluster_of_(static_cast<std::size_t>(graph.numCandidates()), -1),
      base_(graph.initialPoses()) {}

int Rrr::addCluster(const std::vector<int>& members) {
  const int id = numClusters();
  Cluster cluster;
  cluster.members = members;
  for (int k : members) cluster_of_[static_cast<std::size_t>(k)] = id;
  ResidualFunction residuals;
  if (params_.reduced_intra_graph) {
    residuals = [this](const std::vector<int>& links) {
      return reducedGraphResiduals(graph_, links, params_.optimizer);
    };
  } else {
    residuals = [this](const std::vector<int>& links) { return fullGraphResiduals(graph_, links); };
  }
  const IntraClusterResult intra = intraClusterConsistency(members, params_.alpha, residuals);
  optimizations_ += intra.optimizations;
  cluster.kept = intra.kept;
  cluster.status = cluster.kept.empty() ? Status::kInconsistent : Status::kPending;
  clusters_.push_back(cluster);
  kept_links_.push_back(intra.kept);
  return id;
}

std::vector<int> Rrr::clustersWith(Status status) const {
  std::vector<int> ids;
  for (int c = 0; c < numClusters(); ++c) {
    if (clusters_[static_cast<std::size_t>(c)].status == status) ids.push_back(c);
  }
  return ids;
}

bool Rrr::apply(const std::vector<int>& tested, const std::vector<int>& consistent) {
  bool grew = false;
  for (int c : tested) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  for (int c : consistent) {
    grew = grew || std::find(previous_good_.begin(), previous_good_.end(), c) == previous_good_.end();
    clusters_[static_cast<std::size_t>(c)].status = Status::kGood;
  }
  base_ = graph_.optimizer().poses();
  return grew;
}

double Rrr::indexAt(int cluster, const std::vector<core::Pose2>& poses) const {
  const auto& kept = clusters_[static_cast<std::size_t>(cluster)].kept;
  double d2 = 0.0;
  for (int k : kept) {
    const LoopCandidate& c = graph_.candidate(k);
    const Eigen::Vector3d e = core::edgeError(poses[static_cast<std::size_t>(c.from)],
                                              poses[static_cast<std::size_t>(c.to)], c.measurement);
    d2 += e.dot(c.information * e);
  }
  return d2 / core::chi2Quantile(params_.alpha, 3 * static_cast<int>(kept.size()));
}

std::vector<int> Rrr::robustMapLinks(const std::vector<int>& pending) const {
  // Random false links are mostly alone in their cluster, and long single links fill the
  // Cholesky factor; when clusters of two or more links hold most links, they make the map.
  std::vector<int> all, multi;
  auto add = [&](int c) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    all.insert(all.end(), kept.begin(), kept.end());
    if (kept.size() >= 2) multi.insert(multi.end(), kept.begin(), kept.end());
  };
  for (int c : clustersWith(Status::kGood)) add(c);
  for (int c : pending) add(c);
  return 2 * multi.size() >= all.size() ? multi : all;
}

void Rrr::realizeReverseRecover(const std::vector<core::Pose2>& initial, bool robust_ordering) {
  // Realize (and reverse): good + pending clusters, tested jointly.
  previous_good_ = clustersWith(Status::kGood);
  std::vector<int> tested = previous_good_;
  std::vector<core::Pose2> start = initial;
  const std::vector<int> pending = clustersWith(Status::kPending);
  if (robust_ordering && pending.size() > 1) {
    // Many clusters at once: test first those that agree with a map outliers cannot bend; the
    // others are tested in the recover step, against the good set's map.
    start = robustMap(graph_, robustMapLinks(pending), initial, params_.dcs_phi, optimizations_);
    std::vector<int> agreeing, set_aside;
    for (int c : pending) {
      if (std::getenv("RRR_DEBUG_INDEX")) std::fprintf(stderr, "cluster %d size %zu index %.3g\n", c, kept_links_[static_cast<std::size_t>(c)].size(), indexAt(c, start));
      (indexAt(c, start) < 1.0 ? agreeing : set_aside).push_back(c);
    }
    if (agreeing.empty()) {
      // The map agrees with nothing, so it orders nothing: test every cluster, as the paper does.
      agreeing.swap(set_aside);
      start = initial;
    }
    tested.insert(tested.end(), agreeing.begin(), agreeing.end());
    for (int c : set_aside) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  } else {
    tested.insert(tested.end(), pending.begin(), pending.end());
  }
  std::sort(tested.begin(), tested.end());
  InterClusterResult inter = interClusterConsistency(graph_, kept_links_, tested, start,
                                                     params_.alpha, params_.batch_removal_fraction);
  optimizations_ += inter.optimizations;
  if (std::getenv("RRR_DEBUG")) std::fprintf(stderr, "realize: %zu tested, %zu consistent, %d optimizations\n", tested.size(), inter.consistent.size(), inter.optimizations);
  // With robust ordering the clusters set aside count as not yet tried: the good set "grew".
  bool grew = apply(tested, inter.consistent) || (robust_ordering && pending.size() > 1);
  if (progress_) progress_("inter", 1, 1);

  // Recover: while the good set grows, rejected clusters that agree with its map are retried.
  for (int round = 0; grew && round < params_.max_rounds; ++round) {
    std::vector<int> promising;
    for (int c : clustersWith(Status::kRejected)) {
      if (indexAt(c, base_) < params_.recover_gate) promising.push_back(c);
    }
    if (promising.empty()) break;
    previous_good_ = clustersWith(Status::kGood);
    tested = previous_good_;
    tested.insert(tested.end(), promising.begin(), promising.end());
    std::sort(tested.begin(), tested.end());
    const std::vector<core::Pose2> from = base_;
    inter = interClusterConsistency(graph_, kept_links_, tested, from, params_.alpha,
                                    params_.batch_removal_fraction);
    optimizations_ += inter.optimizations;
    if (std::getenv("RRR_DEBUG")) std::fprintf(stderr, "recover %d: %zu promising, %zu tested, %zu consistent, %d optimizations\n", round, promising.size(), tested.size(), inter.consistent.size(), inter.optimizations);
    grew = apply(tested, inter.consistent);
  }
  // Leave the optimizer holding the good set's solution.
  graph_.activateOnly(acceptedCandidates());
  graph_.optimizer().setPoses(base_);
}

void Rrr::decide() { realizeReverseRecover(base_, false); }

void Rrr::decideFromScratch() {
  for (Cluster& c : clusters_) {
    if (c.status != Status::kInconsistent) c.status = Status::kPending;
  }
  base_ = graph_.initialPoses();
  realizeReverseRecover(graph_.initialPoses(), true);
}

Verdict Rrr::verdict(int candidate) const {
  const int c = clusterOf(candidate);
  if (c < 0) return Verdict::kPending;
  const Cluster& cluster = clusters_[static_cast<std::size_t>(c)];
  if (cluster.status == Status::kPending) return Verdict::kPending;
  if (cluster.status != Status::kGood) return Verdict::kRejected;
  const bool kept = std::find(cluster.kept.begin(), cluster.kept.end(), candidate) != cluster.kept.end();
  return kept ? Verdict::kAccepted : Verdict::kRejected;
}

std::vector<int> Rrr::acceptedCandidates() const {
  std::vector<int> links;
  for (const Cluster& c : clusters_) {
    if (c.status == Status::kGood) links.insert(links.end(), c.kept.begin(), c.kept.end());
  }
  std::sort(links.begin(), links.end());
  return links;
}

RrrSummary runBatchRrr(VerificationGraph& graph, const RrrParams& params,
                       std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                       const ProgressFunction& progress) {
  const auto start = std::chrono::steady_clock::now();
  RrrSummary summary;
  summary.candidates = graph.numCandidates();
  std::vector<CandidateEnds> ends;
  for (int k = 0; k < graph.numCandidates(); ++k) ends.emplace_back(graph.candidate(k).from, graph.candidate(k).to);
  summary.cluster_gap = params.cluster_gap > 0 ? params.cluster_gap : deriveClusterGap(ends);
  const auto clusters = clusterCandidates(ends, summary.cluster_gap);
  summary.clusters = static_cast<int>(clusters.size());

  Rrr rrr(graph, params);
  rrr.setProgress(progress);
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    rrr.addCluster(clusters[c]);
    if (progress && (c % 64 == 0 || c + 1 == clusters.size())) {
      progress("intra", static_cast<int>(c + 1), static_cast<int>(clusters.size()));
    }
  }
  const double intra_sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int intra_optimizations = rrr.optimizations();
  rrr.decideFromScratch();
  if (std::getenv("RRR_DEBUG")) {
    std::fprintf(stderr, "intra %.3f s (%d optimizations), decide %.3f s (%d optimizations)\n", intra_sec,
                 intra_optimizations,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - intra_sec,
                 rrr.optimizations() - intra_optimizations);
  }

  verdicts.assign(static_cast<std::size_t>(graph.numCandidates()), Verdict::kPending);
  cluster_of.assign(static_cast<std::size_t>(graph.numCandidates()), -1);
  for (int k = 0; k < graph.numCandidates(); ++k) {
    verdicts[static_cast<std::size_t>(k)] = rrr.verdict(k);
    cluster_of[static_cast<std::size_t>(k)] = rrr.clusterOf(k);
    (verdicts[static_cast<std::size_t>(k)] == Verdict::kAccepted ? summary.accepted : summary.rejected)++;
  }
  summary.optimizations = rrr.optimizations();
  summary.time_sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace rrr_graphslam::rrr
