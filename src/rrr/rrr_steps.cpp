// The additions to the published RRR (each switched by its RrrParams field; what each fixes and
// the measurement behind it: doc/rrr_extensions.md), and the pieces every step shares.

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/session_placement.h"

namespace rrr_graphslam::rrr {

// --- robust_ordering

std::vector<int> Rrr::orderByRobustMap(const std::vector<int>& hypotheses,
                                       std::vector<core::Pose2>& start,
                                       const std::vector<core::Pose2>* previous_map,
                                       bool& previous_won) {
  const Step step(*this, "robust ordering");
  // Many clusters at once: test first those that agree with a map outliers cannot bend; the
  // others are tested in the recover step, against the good set's map.
  const std::vector<core::Pose2> initial = start;
  start = robustOrderingMap(hypotheses, initial, previous_map, previous_won);
  std::vector<int> agreeing, set_aside;
  std::vector<double> set_aside_index;
  for (int c : hypotheses) {
    const double index = indexAt(c, start);
    if (index < 1.0) {
      agreeing.push_back(c);
    } else {
      set_aside.push_back(c);
      set_aside_index.push_back(index);
    }
  }
  if (agreeing.empty()) {
    // The map agrees with nothing, so it orders nothing: test every cluster, as the paper does.
    previous_won = false;
    start = initial;
    return set_aside;
  }
  for (std::size_t i = 0; i < set_aside.size(); ++i) {
    setStatus(set_aside[i], Status::kRejected,
              "robust ordering: " + indexTest("CI", set_aside_index[i]) + " at the robust map");
  }
  // A map the outliers bent (the robust kernel let them pull it into another basin: its trusted
  // constraints fit it worse than all the hypotheses' links together could make them) still
  // orders, but is no place to start the joint test from: from there the optimizations stay in
  // that basin and every cluster fails (a trimmed map's marginal constraints with many large
  // outliers did this). They start from the starting poses, as without robust ordering.
  std::size_t links = 0;
  for (int c : hypotheses) links += kept_links_[static_cast<std::size_t>(c)].size();
  const double bend = graph_.trustedChi2At(start) - graph_.trustedChi2();
  if (bend > core::chi2Quantile(params_.alpha, 3 * static_cast<int>(links))) start = initial;
  return agreeing;
}

std::vector<int> Rrr::robustMapLinks(const std::vector<int>& pending) const {
  // Random false links are mostly alone in their cluster, and long single links fill the
  // Cholesky factor; when clusters of two or more links hold a third of the links or more, they
  // make the map. (At a half, M3500 + 1000 random outliers sat on the line, their share 0.498-
  // 0.503 by seed, and the seeds below it took 45x the time for the same decisions.)
  constexpr double kMultiLinkShare = 1.0 / 3.0;
  std::vector<int> all, multi;
  auto add = [&](int c) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    all.insert(all.end(), kept.begin(), kept.end());
    if (kept.size() >= 2) multi.insert(multi.end(), kept.begin(), kept.end());
  };
  for (int c : clustersWith(Status::kGood)) add(c);
  for (int c : pending) add(c);
  return static_cast<double>(multi.size()) >= kMultiLinkShare * static_cast<double>(all.size())
             ? multi
             : all;
}

std::vector<core::Pose2> Rrr::robustOrderingMap(const std::vector<int>& pending,
                                                const std::vector<core::Pose2>& initial,
                                                const std::vector<core::Pose2>* previous_map,
                                                bool& previous_won) {
  previous_won = false;
  const std::vector<int> links = robustMapLinks(pending);
  std::map<int, int> links_per_time_cluster;
  auto time_cluster = [&](int k) {
    return clusters_[static_cast<std::size_t>(clusterOf(k))].time_cluster;
  };
  for (int k : links) ++links_per_time_cluster[time_cluster(k)];
  std::vector<core::Pose2> full_weight;
  {
    const Step step(*this, "robust ordering: full-weight map");
    full_weight = robustMap(graph_, links, initial, params_.dcs_phi, optimizations_);
  }
  const bool one_link_each = links_per_time_cluster.size() == links.size();
  if (one_link_each && previous_map == nullptr) return full_weight;
  auto support = [&](const std::vector<core::Pose2>& map, const std::vector<int>& clusters) {
    std::size_t agreeing = 0;
    for (int c : clusters) {
      if (indexAt(c, map) < 1.0) agreeing += kept_links_[static_cast<std::size_t>(c)].size();
    }
    return agreeing;
  };
  // Nothing was outvoted when the map agrees with (nearly) every link that made it.
  std::vector<int> voters;
  for (int k : links) voters.push_back(clusterOf(k));
  std::sort(voters.begin(), voters.end());
  voters.erase(std::unique(voters.begin(), voters.end()), voters.end());
  if (support(full_weight, voters) >= links.size() - links.size() / 100) return full_weight;

  // The contenders in order; a later one wins only with strictly more support.
  std::vector<core::Pose2> best = std::move(full_weight);
  std::size_t best_support = support(best, pending);
  auto contend = [&](std::vector<core::Pose2> map) {
    const std::size_t agreeing = support(map, pending);
    if (agreeing <= best_support) return;
    best = std::move(map);
    best_support = agreeing;
  };
  if (!one_link_each) {
    std::vector<double> one_vote;
    one_vote.reserve(links.size());
    for (int k : links) one_vote.push_back(1.0 / links_per_time_cluster[time_cluster(k)]);
    const Step step(*this, "robust ordering: one-vote map");
    contend(robustMap(graph_, links, initial, params_.dcs_phi, optimizations_, one_vote));
  }
  if (previous_map != nullptr) {
    const std::size_t before = best_support;
    const Step step(*this, "robust ordering: previous map");
    contend(robustMap(graph_, links, *previous_map, params_.dcs_phi, optimizations_, {},
                      /*graduated=*/false));
    previous_won = best_support > before;
  }
  return best;
}

// --- place_sessions

std::vector<core::Pose2> Rrr::placeSessions(const std::vector<core::Pose2>& initial,
                                            std::vector<char>* placed_sessions,
                                            const std::vector<core::Pose2>* good_map) const {
  const Step step(*this, "place sessions");
  // Sessions are what trusted constraints hold together (a trimmed session's chains, joined by
  // its marginal constraints, move as one).
  const std::vector<int> session = graph_.trustedComponents();
  const int sessions = VerificationGraph::numComponents(session);
  std::vector<core::Pose2> poses = initial;
  std::vector<char> placed(static_cast<std::size_t>(sessions), 0);
  if (placed_sessions != nullptr) *placed_sessions = std::vector<char>(placed.size(), 1);
  if (sessions < 2) return poses;
  auto of = [&](int node) { return session[static_cast<std::size_t>(node)]; };
  placed[static_cast<std::size_t>(of(0))] = 1;
  // Clusters joining two sessions (a cluster's links all join the same two: clustering.h),
  // largest first by their kept links.
  struct Joining {
    int cluster;
    std::size_t links;
  };
  std::vector<Joining> joining;
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    const auto& kept = kept_links_[c];
    if (kept.empty()) continue;
    const LoopCandidate& first = graph_.candidate(kept.front());
    if (of(first.from) != of(first.to)) joining.push_back({static_cast<int>(c), kept.size()});
  }
  std::stable_sort(joining.begin(), joining.end(),
                   [](const Joining& a, const Joining& b) { return a.links > b.links; });
  // With placement_min_spread_m, a session is placed by the largest cluster of the largest group
  // of its clusters to the placed part that agree on where it lies, and not at all without such
  // a group (session_placement.h).
  std::vector<char> no_group(static_cast<std::size_t>(sessions), 0);
  auto placing_cluster = [&](const Joining& largest, int session_to_place) {
    if (params_.placement_min_spread_m <= 0.0) return largest.cluster;
    std::vector<int> clusters;
    std::vector<JoiningLink> links;
    for (const Joining& j : joining) {
      const int k = kept_links_[static_cast<std::size_t>(j.cluster)].front();
      const LoopCandidate& c = graph_.candidate(k);
      const bool from_placed = placed[static_cast<std::size_t>(of(c.from))] != 0;
      const bool to_placed = placed[static_cast<std::size_t>(of(c.to))] != 0;
      if (from_placed == to_placed || of(from_placed ? c.to : c.from) != session_to_place) continue;
      clusters.push_back(j.cluster);
      links.push_back(from_placed ? JoiningLink{k, c.from, c.to} : JoiningLink{k, c.to, c.from});
    }
    const auto stretch = [&](const std::vector<int>& members) {
      std::vector<int> of_members;
      for (int k : members) of_members.push_back(clusters[static_cast<std::size_t>(k)]);
      return keptLinksSpread(of_members, poses,
                             [&](int node) { return of(node) == session_to_place; });
    };
    const PlacementGroup group =
        placingGroup(good_map != nullptr ? *good_map : poses, links, good_map != nullptr, stretch);
    if (!groupPlaces(group, group.spread_m)) return -1;
    return clusters[static_cast<std::size_t>(group.members.front())];  // `joining` is by size
  };
  for (bool moved = true; moved;) {
    moved = false;
    for (const Joining& largest : joining) {
      const LoopCandidate& first =
          graph_.candidate(kept_links_[static_cast<std::size_t>(largest.cluster)].front());
      const bool first_from_placed = placed[static_cast<std::size_t>(of(first.from))] != 0;
      if (first_from_placed == (placed[static_cast<std::size_t>(of(first.to))] != 0)) continue;
      const int session_to_place = of(first_from_placed ? first.to : first.from);
      if (no_group[static_cast<std::size_t>(session_to_place)] != 0) continue;
      const int cluster = placing_cluster(largest, session_to_place);
      if (cluster < 0) {
        no_group[static_cast<std::size_t>(session_to_place)] = 1;
        continue;
      }
      const LoopCandidate& link =
          graph_.candidate(kept_links_[static_cast<std::size_t>(cluster)].front());
      const bool from_placed = placed[static_cast<std::size_t>(of(link.from))] != 0;
      // The rigid motion of the unplaced end's session to where the link puts that end.
      const int k = kept_links_[static_cast<std::size_t>(cluster)].front();
      const JoiningLink joining_link =
          from_placed ? JoiningLink{k, link.from, link.to} : JoiningLink{k, link.to, link.from};
      const core::Pose2 motion = placingMotion(graph_, poses, joining_link);
      const int moved_session = of(joining_link.session_node);
      for (int n = 0; n < graph_.numNodes(); ++n) {
        if (of(n) == moved_session) {
          poses[static_cast<std::size_t>(n)] =
              core::compose(motion, poses[static_cast<std::size_t>(n)]);
        }
      }
      placed[static_cast<std::size_t>(moved_session)] = 1;
      std::fill(no_group.begin(), no_group.end(), 0);  // the placed part grew: groups may too
      moved = true;
      break;  // the largest cluster joining the grown placed part comes next
    }
  }
  if (placed_sessions != nullptr) *placed_sessions = placed;
  return poses;
}

void Rrr::unplaceLooseSessions() {
  const std::vector<std::size_t> joined = joinedSessions();
  const std::vector<core::Pose2>& initial = graph_.initialPoses();
  bool changed = false;
  for (int n = 0; n < graph_.numNodes(); ++n) {
    if (joined[static_cast<std::size_t>(n)] == joined.front()) continue;
    base_[static_cast<std::size_t>(n)] = initial[static_cast<std::size_t>(n)];
    changed = true;
  }
  // Loose sessions are held only by their weak priors: the good set's optimum is unchanged.
  if (changed) graph_.optimizer().setPoses(base_);
}

// --- settle_good_map

void Rrr::settleGoodMap() {
  const Step step(*this, "settle good map");
  core::Optimizer& opt = graph_.optimizer();
  holdGoodMap();
  const double current = opt.chi2();
  const std::vector<core::Pose2> lago = core::lagoInitialization(opt);
  const core::OptimizationResult r = opt.optimize(core::startFrom(lago));
  ++optimizations_;
  // Lower by more than one link's test threshold: a better minimum, not the same one reached to
  // another tolerance (which could move a session only its weak prior holds). A lower chi2 is a
  // better map even where the run stopped early; a non-finite one (NaN) never compares lower.
  if (r.final_chi2 < current - core::chi2Quantile(params_.alpha, 3)) base_ = opt.poses();
  opt.setPoses(base_);
}

// --- far_retry_min_links

bool Rrr::recoverFar(std::vector<char>& tried) {
  const Step step(*this, "far retry");
  if (params_.far_retry_min_links <= 0) return false;
  std::vector<int> far;
  for (int c : clustersWith(Status::kRejected)) {
    if (!tried[static_cast<std::size_t>(c)] && largeCluster(c)) far.push_back(c);
  }
  if (far.empty()) return false;
  std::stable_sort(far.begin(), far.end(), [&](int a, int b) {
    return kept_links_[static_cast<std::size_t>(a)].size() >
           kept_links_[static_cast<std::size_t>(b)].size();
  });
  core::Optimizer& opt = graph_.optimizer();
  // Each try costs a full optimization: the linearized joint test at the good map (its factor's
  // marginal covariance) screens out clusters no motion the map allows could reconcile with it
  // (City10000 + 1000 random-grouped: false groups at predicted index 200 and more).
  factorGoodMap();
  far.erase(std::remove_if(far.begin(), far.end(),
                           [&](int c) {
                             const std::optional<double> predicted = predictedIndex(c);
                             return predicted && *predicted >= params_.recover_gate;
                           }),
            far.end());
  const double good_chi2 = opt.chi2() - graph_.trustedChi2();
  for (int c : far) {
    tried[static_cast<std::size_t>(c)] = 1;
    std::vector<int> tested = clustersWith(Status::kGood);
    tested.push_back(c);
    std::vector<int> links = acceptedCandidates();
    const auto& own = kept_links_[static_cast<std::size_t>(c)];
    links.insert(links.end(), own.begin(), own.end());
    const core::OptimizationResult r = graph_.optimize(links, core::startFrom(base_));
    ++optimizations_;
    const std::vector<core::Pose2>& poses = opt.poses();
    // Accepted only as is: the joint test passes, no cluster, good or new, had to go, and the
    // cluster raised the good set's chi2 by less than its own test threshold. (A pass at a
    // non-converged point holds: the minimum's chi2 is lower still.)
    const double chi2 = failIfNotFinite(opt.chi2()) - graph_.trustedChi2();
    const int dof = 3 * static_cast<int>(links.size());
    const int own_dof = 3 * static_cast<int>(own.size());
    bool consistent = chi2 < core::chi2Quantile(params_.alpha, dof) &&
                      increaseFits(chi2 - good_chi2, static_cast<int>(own.size()));
    for (std::size_t i = 0; consistent && i < tested.size(); ++i) {
      consistent = indexAt(tested[i], poses) < 1.0;
    }
    if (consistent) {
      setStatus(c, Status::kGood,
                "far retry: " + chi2Test("D2_G", chi2, params_.alpha, dof) + ", increase " +
                    chi2Test("D2", chi2 - good_chi2, params_.alpha, own_dof) +
                    stopNote(r.stop_reason));
      base_ = poses;
      return true;
    }
  }
  return false;
}

// --- leave_one_out_check

bool Rrr::leaveOneOutCheck() {
  const Step step(*this, "leave-one-out check");
  factorGoodMap();
  std::vector<int> examined;
  std::vector<const std::vector<int>*> links;
  for (int c : clustersWith(Status::kGood)) {
    if (!largeCluster(c) && indexAt(c, base_) < params_.loo_min_index) continue;
    examined.push_back(c);
    links.push_back(&kept_links_[static_cast<std::size_t>(c)]);
  }
  const std::vector<double> index = leaveOneOutIndices(graph_, links, base_, params_.alpha);
  std::vector<int> conflicting;
  std::vector<double> conflicting_index;
  for (std::size_t i = 0; i < examined.size(); ++i) {
    if (index[i] >= 1.0) {
      conflicting.push_back(examined[i]);
      conflicting_index.push_back(index[i]);
    }
  }
  if (conflicting.empty())
    return params_.loo_joint_min_index > 0.0 && jointLeaveOut(examined, index);
  for (std::size_t i = 0; i < conflicting.size(); ++i) {
    setStatus(conflicting[i], Status::kRejected,
              "leave-one-out: " + indexTest("index", conflicting_index[i]));
  }
  optimizeGoodMap();
  return true;
}

bool Rrr::jointLeaveOut(const std::vector<int>& examined, const std::vector<double>& index) {
  std::vector<int> suspects, together;
  std::size_t worst = 0;
  for (std::size_t i = 0; i < examined.size(); ++i) {
    if (index[i] < params_.loo_joint_min_index) continue;
    if (suspects.empty() || index[i] > index[worst]) worst = i;
    suspects.push_back(examined[i]);
    const auto& kept = kept_links_[static_cast<std::size_t>(examined[i])];
    together.insert(together.end(), kept.begin(), kept.end());
  }
  if (suspects.size() < 2) return false;
  const double joint = leaveOneOutIndices(graph_, {&together}, base_, params_.alpha).front();
  if (joint < 1.0) return false;
  setStatus(examined[worst], Status::kRejected,
            "joint leave-out: " + indexTest("index", joint) + " with " +
                std::to_string(suspects.size()) + " clusters left out together, " +
                indexTest("its own", index[worst]));
  optimizeGoodMap();
  // The others are examined again against the map without it.
  leaveOneOutCheck();
  return true;
}

// --- joint_link_check

bool Rrr::jointLinkCheck() {
  const Step step(*this, "joint link check");
  const double threshold = core::chi2Quantile(params_.alpha, 3);
  bool dropped_any = false;
  for (int round = 0; round < params_.max_rounds; ++round) {
    // The worst failing link of each good cluster.
    struct Failing {
      double chi2;
      std::size_t cluster;
      std::size_t at;  // in the cluster's kept links
    };
    std::vector<Failing> failing;
    double worst = 0.0;
    for (int c : clustersWith(Status::kGood)) {
      const auto& kept = kept_links_[static_cast<std::size_t>(c)];
      Failing f{threshold, static_cast<std::size_t>(c), kept.size()};
      for (std::size_t i = 0; i < kept.size(); ++i) {
        const double d2 = failIfNotFinite(linkChi2(kept[i], base_));
        if (d2 >= f.chi2) f = {d2, f.cluster, i};
      }
      if (f.at == kept.size()) continue;
      failing.push_back(f);
      worst = std::max(worst, f.chi2);
    }
    if (failing.empty()) break;
    for (const Failing& f : failing) {
      if (f.chi2 < params_.batch_removal_fraction * worst) continue;
      auto& kept = kept_links_[f.cluster];
      link_reason_[static_cast<std::size_t>(kept[f.at])] =
          "joint link check: " + chi2Test("D2_l", f.chi2, params_.alpha, 3);
      kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(f.at));
      // No link left: out of every test until the next decision from scratch.
      if (kept.empty()) clusters_[f.cluster].status = Status::kInconsistent;
    }
    dropped_any = true;
    optimizeGoodMap();
  }
  return dropped_any;
}

// --- Shared pieces

void Rrr::syncWithGraph() {
  cluster_of_.resize(static_cast<std::size_t>(graph_.numCandidates()), -1);
  link_reason_.resize(static_cast<std::size_t>(graph_.numCandidates()));
  graph_.extendByOdometry(base_);
}

std::vector<core::Pose2> Rrr::mapEstimate() const {
  std::vector<core::Pose2> poses = base_;
  graph_.extendByOdometry(poses);
  return poses;
}

void Rrr::seedPreviousMap(std::vector<core::Pose2> map) {
  if (map.size() != static_cast<std::size_t>(graph_.numNodes())) {
    throw std::invalid_argument("seedPreviousMap: " + std::to_string(map.size()) +
                                " poses for a graph of " + std::to_string(graph_.numNodes()) +
                                " nodes");
  }
  seeded_map_ = std::move(map);
}

std::vector<int> Rrr::clustersWith(Status status) const {
  std::vector<int> ids;
  for (int c = 0; c < numClusters(); ++c) {
    if (clusters_[static_cast<std::size_t>(c)].status == status) ids.push_back(c);
  }
  return ids;
}

void Rrr::setStatus(int cluster, Status status, std::string reason) {
  Cluster& c = clusters_[static_cast<std::size_t>(cluster)];
  c.status = status;
  c.reason = std::move(reason);
}

bool Rrr::largeCluster(int cluster) const {
  return params_.far_retry_min_links > 0 &&
         kept_links_[static_cast<std::size_t>(cluster)].size() >=
             static_cast<std::size_t>(params_.far_retry_min_links);
}

double Rrr::linkChi2(int candidate, const std::vector<core::Pose2>& poses) const {
  const LoopCandidate& c = graph_.candidate(candidate);
  const Eigen::Vector3d e = core::edgeError(poses[static_cast<std::size_t>(c.from)],
                                            poses[static_cast<std::size_t>(c.to)], c.measurement);
  return e.dot(c.information * e);
}

double Rrr::indexAt(int cluster, const std::vector<core::Pose2>& poses) const {
  const auto& kept = kept_links_[static_cast<std::size_t>(cluster)];
  double d2 = 0.0;
  for (int k : kept) d2 += linkChi2(k, poses);
  return failIfNotFinite(d2 / core::chi2Quantile(params_.alpha, 3 * static_cast<int>(kept.size())));
}

void Rrr::optimizeGoodMap() {
  const Step step(*this, "good map");
  graph_.optimize(acceptedCandidates(), core::startFrom(base_));
  ++optimizations_;
  base_ = graph_.optimizer().poses();
}

void Rrr::holdGoodMap() {
  graph_.activateOnly(acceptedCandidates());
  graph_.optimizer().setPoses(base_);
}

void Rrr::factorGoodMap() {
  const Step step(*this, "good map factorization");
  holdGoodMap();
  // Otherwise one undamped factorization at the solution; where that optimization ends damped
  // (at its iteration limit: ringCity with aliased groups), a factorization where it stopped.
  // Without it covariance() is zero and the linearized tests weigh the residual alone.
  if (!graph_.optimizer().covarianceAvailable()) optimizeGoodMap();
  if (!graph_.optimizer().covarianceAvailable()) graph_.optimizer().factorAtCurrentPoses();
}

std::optional<double> Rrr::predictedIndex(int cluster) const {
  return rrr::predictedIndex(graph_, kept_links_[static_cast<std::size_t>(cluster)], base_,
                             params_.alpha);
}

}  // namespace rrr_graphslam::rrr
