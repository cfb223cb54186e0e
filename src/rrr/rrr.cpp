// RRR's decision as the paper states it (Latif, Cadena, Neira, IJRR 2013): Algorithm 1 in
// addCluster, Algorithm 3 in decideFromScratch. The additions it calls are in rrr_steps.cpp, the
// incremental decision in rrr_online.cpp.

#include "rrr_graphslam/rrr/rrr.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/rrr/pairwise_consistency.h"

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
      link_reason_(static_cast<std::size_t>(graph.numCandidates())),
      base_(graph.initialPoses()) {
  validate(params_);
  if (params_.reduced_intra_graph) {
    residuals_ = [this](const std::vector<int>& links) {
      return reducedGraphResiduals(graph_, links, params_.optimizer);
    };
  } else {
    residuals_ = [this](const std::vector<int>& links) {
      return fullGraphResiduals(graph_, links);
    };
  }
}

// Algorithm 1 (with split_mixed_clusters: a cluster failing as a whole is split first).
int Rrr::addCluster(const std::vector<int>& members) {
  const Step step(*this, "intra-cluster test");
  syncWithGraph();
  ++time_clusters_;
  if (!params_.split_mixed_clusters || members.size() < 2) {
    addTestedCluster(members, nullptr);
    return 1;
  }
  const LinkResiduals whole = residuals_(members);
  ++optimizations_;
  if (whole.total_chi2 < core::chi2Quantile(params_.alpha, 3 * static_cast<int>(members.size()))) {
    addTestedCluster(members, &whole);
    return 1;
  }
  const std::vector<std::vector<int>> groups =
      splitByPairwiseConsistency(graph_, members, params_.alpha);
  for (const std::vector<int>& group : groups) addTestedCluster(group, nullptr);
  return static_cast<int>(groups.size());
}

void Rrr::addTestedCluster(const std::vector<int>& members, const LinkResiduals* whole) {
  const int id = numClusters();
  Cluster cluster;
  cluster.time_cluster = time_clusters_ - 1;
  cluster.members = members;
  for (int k : members) cluster_of_[static_cast<std::size_t>(k)] = id;
  // The whole cluster's joint test, when addCluster ran it already, is not run twice.
  bool reused = false;
  const ResidualFunction residuals = [&](const std::vector<int>& links) {
    if (whole != nullptr && links == members) {
      reused = true;
      return *whole;
    }
    return residuals_(links);
  };
  const IntraClusterResult intra =
      intraClusterConsistency(members, params_.alpha, residuals, params_.intra_worst_link_removal);
  optimizations_ += intra.optimizations - (reused ? 1 : 0);  // addCluster counted that one
  for (std::size_t i = 0; i < intra.dropped.size(); ++i) {
    link_reason_[static_cast<std::size_t>(intra.dropped[i])] =
        "intra-cluster: " + intra.why_dropped[i];
  }
  cluster.passed = intra.kept;
  cluster.status = cluster.passed.empty() ? Status::kInconsistent : Status::kPending;
  clusters_.push_back(cluster);
  kept_links_.push_back(intra.kept);
}

// Algorithm 3. Hypotheses are the clusters neither good nor rejected (status kPending).
void Rrr::decideFromScratch() {
  const Step step(*this, "decision from scratch");
  syncWithGraph();
  // The previous map (a seeded one, or the last decision's solution), which its loops made
  // better than odometry, places sessions and, with several sessions, is one of the robust
  // ordering's maps.
  const bool seeded = !seeded_map_.empty();
  std::vector<core::Pose2> previous_map = seeded ? seeded_map_ : base_;
  if (seeded) graph_.extendByOdometry(previous_map);  // nodes added since it was seeded
  const bool have_map = base_is_solution_ || seeded;
  seeded_map_.clear();
  const std::vector<core::Pose2>* placement_map = have_map ? &previous_map : nullptr;
  // The previous map is a contender where the initial estimate is poorest: several sessions
  // (parts no trusted constraint joins), each placed rigidly by one cluster. Within one session
  // it would only repeat an earlier decision made on part of the same candidates (measured:
  // doc/rrr_extensions.md#measured-and-not-adopted).
  if (!have_map || !params_.robust_ordering || graph_.numTrustedComponents() < 2) {
    decideOnce(placement_map, nullptr);
    return;
  }
  const DecisionState before = decisionState();
  if (!decideOnce(placement_map, &previous_map)) return;
  // The previous map ordered the work. A map that more links agree with need not lead to the
  // decision that keeps more of them (an earlier decision's false groups agree with its map):
  // the decision is made again as without it, and the one that accepts more links is kept (the
  // larger consensus; a tie keeps the one without it).
  const std::size_t accepted_with_previous = acceptedCandidates().size();
  DecisionState with_previous = decisionState();
  restoreDecisionState(before);
  decideOnce(placement_map, nullptr);
  if (acceptedCandidates().size() >= accepted_with_previous) return;
  restoreDecisionState(std::move(with_previous));
  holdGoodMap();
}

Rrr::DecisionState Rrr::decisionState() const {
  return {clusters_,         kept_links_,    link_reason_,  base_,
          base_is_solution_, previous_good_, last_removed_, unoptimized_accepts_};
}

void Rrr::restoreDecisionState(DecisionState state) {
  clusters_ = std::move(state.clusters);
  kept_links_ = std::move(state.kept_links);
  link_reason_ = std::move(state.link_reason);
  base_ = std::move(state.base);
  base_is_solution_ = state.base_is_solution;
  previous_good_ = std::move(state.previous_good);
  last_removed_ = std::move(state.last_removed);
  unoptimized_accepts_ = state.unoptimized_accepts;
}

bool Rrr::decideOnce(const std::vector<core::Pose2>* placement_map,
                     const std::vector<core::Pose2>* ordering_map) {
  startFromIntraResults();
  std::vector<char> placed_sessions;
  const std::vector<core::Pose2> initial =
      params_.place_sessions ? placeSessions(graph_.initialPoses(), &placed_sessions, placement_map)
                             : graph_.initialPoses();
  if (params_.place_sessions && params_.placement_min_spread_m > 0.0) {
    holdUnplacedSessions(placed_sessions);
  }
  base_ = initial;

  // Realize: the hypotheses are tested jointly; the consistent ones become the good set. The
  // paper tests those the hypotheses' own map preselects; robust_ordering those a robust map
  // agrees with (the others wait for the recover step).
  std::vector<core::Pose2> start = initial;
  std::vector<int> hypotheses = clustersWith(Status::kPending);
  const bool ordered = params_.robust_ordering && hypotheses.size() > 1;
  bool previous_won = false;
  if (ordered) {
    hypotheses = orderByRobustMap(hypotheses, start, ordering_map, previous_won);
  } else if (!params_.robust_ordering) {
    hypotheses = preselect(hypotheses);
  }
  // With robust ordering the clusters set aside count as not yet tried: the good set "grew".
  bool grew = realize(hypotheses, start, "realize", false) || ordered;
  if (progress_) progress_("inter", 1, 1);
  if (params_.settle_good_map) settleGoodMap();

  // Recover (and reverse): while the good set grows, rejected clusters become hypotheses again
  // and are tested with it; a good cluster that fails with them is reversed. When none is left,
  // large clusters far from the map get a direct test each (far retry).
  std::vector<char> far_tried(clusters_.size(), 0);
  for (int round = 0; round < params_.max_rounds; ++round) {
    hypotheses = recoverHypotheses(grew);
    if (!params_.robust_ordering) hypotheses = preselect(hypotheses);
    if (hypotheses.empty()) {
      if (!recoverFar(far_tried)) break;
      grew = true;
      continue;
    }
    grew = realize(hypotheses, params_.warm_start ? base_ : initial, "recover", false);
  }
  // Hypotheses never selected again are rejected, with their last preselection's statistic.
  for (int c : clustersWith(Status::kPending)) {
    const std::string why = clusters_[static_cast<std::size_t>(c)].reason;
    setStatus(c, Status::kRejected, why.empty() ? "preselection: never tested" : why);
  }
  // Leave the optimizer holding the good set's solution.
  holdGoodMap();

  if (params_.leave_one_out_check) leaveOneOutCheck();
  if (params_.joint_link_check) jointLinkCheck();
  if (params_.placement_min_spread_m > 0.0 && holdLoosePlacements()) optimizeGoodMap();
  if (params_.place_sessions) unplaceLooseSessions();
  return previous_won;
}

void Rrr::startFromIntraResults() {
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    // Every link that passed the intra test takes part again, those the last joint link check
    // dropped included.
    Cluster& cluster = clusters_[c];
    kept_links_[c] = cluster.passed;
    cluster.status = cluster.passed.empty() ? Status::kInconsistent : Status::kPending;
    cluster.reason.clear();
  }
  base_ = graph_.initialPoses();
  base_is_solution_ = false;
  unoptimized_accepts_ = 0;
  revisits_tried_.clear();
  good_when_tried_.clear();
  last_removed_.clear();
}

std::vector<int> Rrr::preselect(const std::vector<int>& hypotheses) {
  const Step profiled(*this, "preselection");
  if (hypotheses.empty()) return {};
  std::vector<int> links;
  for (int c : hypotheses) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    links.insert(links.end(), kept.begin(), kept.end());
  }
  const core::OptimizationResult r = graph_.optimize(links, core::startFrom(graph_.initialPoses()));
  ++optimizations_;
  const core::Optimizer& opt = graph_.optimizer();
  const double threshold = core::chi2Quantile(params_.alpha, 3);
  std::vector<int> selected;
  for (int c : hypotheses) {
    double best = std::numeric_limits<double>::infinity();
    for (int k : kept_links_[static_cast<std::size_t>(c)]) {
      best = std::min(best, failIfNotFinite(opt.constraintChi2(graph_.candidate(k).constraint)));
    }
    if (best < threshold) {
      selected.push_back(c);
      continue;
    }
    // Not selected: a hypothesis still; rejected for this reason if never selected again.
    clusters_[static_cast<std::size_t>(c)].reason =
        "preselection: " + chi2Test("min D2_l", best, params_.alpha, 3) + stopNote(r.stop_reason);
  }
  return selected;
}

bool Rrr::realize(const std::vector<int>& hypotheses, const std::vector<core::Pose2>& start,
                  const char* step, bool restart, bool factor_at_solution) {
  const Step profiled(*this, step);
  previous_good_ = clustersWith(Status::kGood);
  std::vector<int> tested = previous_good_;
  tested.insert(tested.end(), hypotheses.begin(), hypotheses.end());
  std::sort(tested.begin(), tested.end());
  const InterClusterResult inter =
      interClusterConsistency(graph_, kept_links_, tested, start, params_.alpha,
                              params_.batch_removal_fraction, restart || !params_.warm_start,
                              params_.reverse_good_clusters ? std::vector<int>{} : previous_good_,
                              params_.conflict_removal);
  optimizations_ += inter.optimizations;
  if (factor_at_solution && !graph_.optimizer().covarianceAvailable()) {
    graph_.optimizer().optimize();  // ends undamped, so the next clusters can use the gate
    ++optimizations_;
  }
  return apply(tested, inter, step);
}

std::vector<int> Rrr::recoverHypotheses(bool grew) {
  if (grew && std::isinf(params_.recover_gate)) {
    for (int c : clustersWith(Status::kRejected)) {
      if (!std::binary_search(last_removed_.begin(), last_removed_.end(), c)) {
        setStatus(c, Status::kPending, "");
      }
    }
  }
  std::vector<int> hypotheses = clustersWith(Status::kPending);
  if (!grew || std::isinf(params_.recover_gate)) return hypotheses;
  for (int c : clustersWith(Status::kRejected)) {
    if (indexAt(c, base_) < params_.recover_gate) hypotheses.push_back(c);
  }
  std::sort(hypotheses.begin(), hypotheses.end());
  return hypotheses;
}

bool Rrr::apply(const std::vector<int>& tested, const InterClusterResult& inter, const char* step) {
  auto was_good = [&](int c) {
    // previous_good_ comes from clustersWith(), in increasing id order.
    return std::binary_search(previous_good_.begin(), previous_good_.end(), c);
  };
  for (int c : tested) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  for (std::size_t i = 0; i < inter.removed.size(); ++i) {
    const int c = inter.removed[i];
    setStatus(c, Status::kRejected,
              std::string(was_good(c) ? "reverse" : step) + ": " + inter.why_removed[i]);
  }
  last_removed_ = inter.removed;
  std::sort(last_removed_.begin(), last_removed_.end());
  bool grew = false;
  std::string joint;  // the joint test's statistic, for the clusters that become good
  for (std::size_t i = 0; i < inter.consistent.size(); ++i) {
    const int c = inter.consistent[i];
    if (was_good(c)) {
      clusters_[static_cast<std::size_t>(c)].status = Status::kGood;
      continue;
    }
    grew = true;
    if (joint.empty()) {
      joint = chi2Test("D2_G", inter.chi2, params_.alpha, std::max(inter.dof, 1)) +
              stopNote(inter.stop);
    }
    setStatus(c, Status::kGood,
              std::string(step) + ": " + indexTest("CI", inter.consistent_index[i]) + ", " + joint);
  }
  base_ = graph_.optimizer().poses();
  base_is_solution_ = true;
  return grew;
}

Verdict Rrr::verdict(int candidate) const {
  const int c = clusterOf(candidate);  // -1 also for candidates added since the last call
  if (c < 0) return Verdict::kPending;
  const Cluster& cluster = clusters_[static_cast<std::size_t>(c)];
  if (cluster.status == Status::kPending || cluster.status == Status::kUnplaced) {
    return Verdict::kPending;
  }
  if (cluster.status != Status::kGood) return Verdict::kRejected;
  const auto& kept = kept_links_[static_cast<std::size_t>(c)];
  return std::find(kept.begin(), kept.end(), candidate) != kept.end() ? Verdict::kAccepted
                                                                      : Verdict::kRejected;
}

std::string Rrr::reason(int candidate) const {
  const int c = clusterOf(candidate);
  if (c < 0) return "open cluster: awaits its intra-cluster test";
  const Cluster& cluster = clusters_[static_cast<std::size_t>(c)];
  const auto& kept = kept_links_[static_cast<std::size_t>(c)];
  const bool in_kept = std::find(kept.begin(), kept.end(), candidate) != kept.end();
  if (!in_kept) return link_reason_[static_cast<std::size_t>(candidate)];
  if (cluster.status == Status::kPending && cluster.reason.empty()) {
    return "intra-cluster: passed; awaits a joint test";
  }
  return cluster.reason;
}

bool Rrr::passedIntraTest(int candidate) const {
  const int c = clusterOf(candidate);
  if (c < 0) return true;
  const auto& passed = clusters_[static_cast<std::size_t>(c)].passed;
  return std::find(passed.begin(), passed.end(), candidate) != passed.end();
}

std::vector<int> Rrr::acceptedCandidates() const {
  std::vector<int> links;
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    if (clusters_[c].status != Status::kGood) continue;
    links.insert(links.end(), kept_links_[c].begin(), kept_links_[c].end());
  }
  std::sort(links.begin(), links.end());
  return links;
}

}  // namespace rrr_graphslam::rrr
