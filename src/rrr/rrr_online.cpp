// The online step of incremental RRR (Latif, Cadena, Neira, IROS 2012): clusters just closed are
// decided against the good set's map, and jointly with the good set when the map cannot tell.

#include <algorithm>
#include <cstdlib>
#include <optional>
#include <utility>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/rrr/linearized_tests.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {

void Rrr::decideIncrementally() {
  const Step step(*this, "online decision");
  syncWithGraph();
  // Nodes added since the last joint test hang from the map by odometry; their covariance is
  // propagated along it at the map's poses (Optimizer::covariance).
  graph_.optimizer().setPoses(base_);
  // Online settings of the optimizer for this call; the final decision keeps the caller's.
  core::OptimizerParams& optimizer = graph_.optimizer().params();
  struct Restore {
    core::OptimizerParams& params;
    core::OptimizerParams saved;
    ~Restore() { params = saved; }
  } restore{optimizer, optimizer};
  optimizer.factor_updates = params_.incremental_factor_updates;
  optimizer.relative_tolerance =
      std::max(optimizer.relative_tolerance, params_.incremental_relative_tolerance);
  decideAgainstMap();
}

Rrr::OnlineVerdict Rrr::checkAgainstMap(int cluster, double& statistic) const {
  const Step step(*this, "online map check");
  if (!params_.online_map_check) return OnlineVerdict::kNeedsJointTest;
  statistic = indexAt(cluster, base_);
  if (statistic < 1.0) return OnlineVerdict::kFits;
  // Accepting on the linearized test alone let doubtful clusters into the map updates, whose
  // removal rounds then cost more than the joint tests saved (measured on M3500 and City10000).
  const std::optional<double> predicted = predictedIndex(cluster);
  if (predicted && *predicted >= 1.0) {
    statistic = *predicted;
    return OnlineVerdict::kDoesNotFit;
  }
  // The map would have to move to fit it. A lone link where the map leaves its relative pose open
  // would pass the joint test wherever it points (the nodes move to fit it): it waits.
  if (mayWaitForTheMap(cluster)) {
    const std::optional<double> ratio =
        mapUncertaintyRatio(graph_, kept_links_[static_cast<std::size_t>(cluster)], base_);
    if (ratio && *ratio > params_.online_untestable_ratio) {
      statistic = *ratio;
      return OnlineVerdict::kUntestable;
    }
  }
  return OnlineVerdict::kNeedsJointTest;
}

bool Rrr::mayWaitForTheMap(int cluster) const {
  const auto& kept = kept_links_[static_cast<std::size_t>(cluster)];
  if (params_.online_untestable_ratio <= 0.0 || kept.empty()) return false;
  // A link to another session is the placement rules' (a session not yet tied hangs from nothing;
  // a cluster's links all join the same two sessions).
  const LoopCandidate& first = graph_.candidate(kept.front());
  if (!graph_.chain().sameSession(first.from, first.to)) return false;
  if (kept.size() == 1) return true;
  // Several links: a revisit (a loop within the robot's recent path says nothing about where
  // that path lies in the map), within its wait.
  const int wait = params_.online_group_wait_nodes;
  if (wait <= 0) return false;
  int newest = 0;
  for (int k : kept) {
    const LoopCandidate& link = graph_.candidate(k);
    if (std::abs(link.to - link.from) <= wait) return false;
    newest = std::max({newest, link.from, link.to});
  }
  return graph_.numNodes() - 1 - newest <= wait;  // the robot's newest node at most N past it
}

bool Rrr::acceptAgreeingRevisits(const std::vector<int>& waiting) {
  const Step step(*this, "revisits");
  std::vector<int> revisits;
  for (int c : waiting) {
    if (kept_links_[static_cast<std::size_t>(c)].size() >= 2) revisits.push_back(c);
  }
  if (revisits.size() < 2) return false;
  std::vector<int> good = clustersWith(Status::kGood);
  if (revisits == revisits_tried_ && good == good_when_tried_) return false;
  const DecisionState before = decisionState();
  const double good_chi2_before = goodSetChi2();
  // While the test fails with three or more passing, the one whose removal would take the most
  // chi2 off the joint solution (leave-one-out index) leaves and the others are tested again: a
  // false revisit can pass the joint test beside true ones by bending the path they hang from.
  std::vector<int> tested = revisits;
  while (tested.size() >= 2) {
    realize(tested, base_, "revisits tested together", true, true);
    std::vector<int> passed;
    int links = 0;
    for (int c : tested) {
      if (clusters_[static_cast<std::size_t>(c)].status != Status::kGood) continue;
      passed.push_back(c);
      links += static_cast<int>(kept_links_[static_cast<std::size_t>(c)].size());
    }
    const bool good_kept = std::all_of(good.begin(), good.end(), [&](int c) {
      return clusters_[static_cast<std::size_t>(c)].status == Status::kGood;
    });
    // Two revisits that agree with each other and with the map say where the path lies; one
    // alone (the others removed) says no more than it did waiting. They only add to the good
    // set: were a good cluster reversed, its chi2 would leave the increase with it.
    if (passed.size() >= 2 && good_kept && increaseFits(goodSetChi2() - good_chi2_before, links)) {
      if (!params_.online_scratch_check) return true;
      const std::vector<std::pair<int, std::string>> rejected = rejectedFromScratch(passed);
      if (rejected.empty()) return true;
      restoreDecisionState(before);
      rejectAsFromScratch(rejected, "revisits");
      revisits_tried_.clear();  // the others wait, and are tried again
      return false;
    }
    const bool retry = passed.size() >= 3 && graph_.optimizer().covarianceAvailable();
    if (retry) {
      std::vector<const std::vector<int>*> link_sets;
      for (int c : passed) link_sets.push_back(&kept_links_[static_cast<std::size_t>(c)]);
      const std::vector<double> index =
          leaveOneOutIndices(graph_, link_sets, graph_.optimizer().poses(), params_.alpha);
      passed.erase(passed.begin() + (std::max_element(index.begin(), index.end()) - index.begin()));
    }
    restoreDecisionState(before);
    holdGoodMap();
    if (!retry) break;
    tested = std::move(passed);
  }
  revisits_tried_ = std::move(revisits);
  good_when_tried_ = std::move(good);
  return false;
}

bool Rrr::increaseFits(double increase, int links) const {
  return increase < core::chi2Quantile(params_.alpha, 3 * links);
}

double Rrr::goodSetChi2() const {
  double d2 = graph_.trustedChi2At(base_) - graph_.trustedChi2();
  for (int k : acceptedCandidates()) d2 += linkChi2(k, base_);
  return d2;
}

std::vector<int> Rrr::addedSince(const DecisionState& before) const {
  std::vector<int> added;
  for (int c : clustersWith(Status::kGood)) {
    if (before.clusters[static_cast<std::size_t>(c)].status != Status::kGood) added.push_back(c);
  }
  return added;
}

std::vector<std::pair<int, std::string>> Rrr::rejectedFromScratch(const std::vector<int>& added) {
  std::vector<int> groups;
  for (int c : added) {
    if (kept_links_[static_cast<std::size_t>(c)].size() >= 2) groups.push_back(c);
  }
  // Several sessions are decided from scratch every incremental_rebatch_every nodes already, and
  // such a decision (placements, the previous map as a contender) costs far more than one of a
  // single run. (Counting the components walks the graph: only when there is a group.)
  if (groups.empty() || graph_.numTrustedComponents() > 1) return {};
  const Step step(*this, "online scratch check");
  DecisionState online = decisionState();
  decideFromScratch();
  std::vector<std::pair<int, std::string>> rejected;
  for (int c : groups) {
    const Cluster& cluster = clusters_[static_cast<std::size_t>(c)];
    if (cluster.status != Status::kGood) rejected.emplace_back(c, cluster.reason);
  }
  restoreDecisionState(std::move(online));
  holdGoodMap();
  factorGoodMap();
  return rejected;
}

void Rrr::rejectAsFromScratch(const std::vector<std::pair<int, std::string>>& rejected,
                              const char* step) {
  for (const auto& [c, why] : rejected) {
    setStatus(c, Status::kRejected,
              std::string(step) + ": a decision from scratch rejects it (" + why + ")");
  }
  holdGoodMap();
}

bool Rrr::undoIfScratchRejects(DecisionState& before, std::vector<int>& tested) {
  const std::vector<std::pair<int, std::string>> rejected = rejectedFromScratch(addedSince(before));
  if (rejected.empty()) return false;
  restoreDecisionState(std::move(before));
  rejectAsFromScratch(rejected, "online");
  for (const auto& rejection : rejected) {
    tested.erase(std::remove(tested.begin(), tested.end(), rejection.first), tested.end());
  }
  return true;
}

bool Rrr::undoIfIncreaseFails(DecisionState& before, double good_chi2_before) {
  const Step step(*this, "online increase test");
  const std::vector<int> added = addedSince(before);
  int links = 0;
  for (int c : added) links += static_cast<int>(kept_links_[static_cast<std::size_t>(c)].size());
  if (added.empty()) return false;
  const double increase = goodSetChi2() - good_chi2_before;
  if (increaseFits(increase, links)) return false;
  restoreDecisionState(std::move(before));
  for (int c : added) {
    setStatus(c, Status::kRejected,
              "online: joint increase " + chi2Test("D2", increase, params_.alpha, 3 * links));
  }
  holdGoodMap();
  return true;
}

void Rrr::refreshGoodMap() {
  optimizeGoodMap();
  factorGoodMap();
  unoptimized_accepts_ = 0;
}

void Rrr::decideAgainstMap() {
  std::vector<int> joint;
  std::vector<int> placing_groups;  // in `joint`: groups placing an untied session
  std::vector<int> waiting;         // clusters the map cannot test yet
  bool factored = false;            // a factor of the good map was made for this decision
  auto sort_out = [&](int c, const char* step) {
    double statistic = 0.0;
    OnlineVerdict verdict = checkAgainstMap(c, statistic);
    // Whether a lone link can be tested is read from the good map's factor: made once here, at
    // the map's poses, if the last joint test left none usable.
    if (verdict == OnlineVerdict::kNeedsJointTest && mayWaitForTheMap(c) && !factored &&
        !graph_.optimizer().covarianceAvailable()) {
      factored = true;
      holdGoodMap();
      graph_.optimizer().factorAtCurrentPoses();
      verdict = checkAgainstMap(c, statistic);
    }
    switch (verdict) {
      case OnlineVerdict::kFits:
        setStatus(c, Status::kGood,
                  std::string(step) + ": " + indexTest("CI", statistic) + " at the good map");
        ++unoptimized_accepts_;
        break;
      case OnlineVerdict::kDoesNotFit:
        setStatus(c, Status::kRejected,
                  std::string(step) + ": linearized joint " + indexTest("index", statistic));
        break;
      case OnlineVerdict::kNeedsJointTest:
        joint.push_back(c);
        break;
      case OnlineVerdict::kUntestable:
        setStatus(
            c, Status::kPending,
            std::string(step) + ": waits for the map: " +
                indexTest("map / link uncertainty", statistic, params_.online_untestable_ratio));
        waiting.push_back(c);
        break;
    }
  };
  // Clusters joining a session not yet tied to the map wait for a group of them that places it
  // (placement_min_spread_m): the group is tested jointly, the others once the session is tied.
  auto admit = [&](std::vector<int> clusters, const char* step) {
    if (params_.placement_min_spread_m > 0.0) {
      const std::vector<int> unplaced = clustersWith(Status::kUnplaced);
      clusters.insert(clusters.end(), unplaced.begin(), unplaced.end());
      const std::vector<int> groups = takePlacingClusters(clusters);
      joint.insert(joint.end(), groups.begin(), groups.end());
      placing_groups.insert(placing_groups.end(), groups.begin(), groups.end());
    }
    for (int c : clusters) sort_out(c, step);
  };
  admit(clustersWith(Status::kPending), "online");
  // Clusters accepted on the map's word (here or before) are not in its factor yet, and may hold
  // the path a waiting link hangs from: the map takes them in and the waiting links are checked
  // again (after a joint test that grows the good set, the recover step below does it).
  if (!waiting.empty() && unoptimized_accepts_ > 0) {
    refreshGoodMap();
    for (int c : std::exchange(waiting, {})) sort_out(c, "online");
  }
  // Revisits waiting for one another: two that agree are accepted together, and the clusters
  // they may have pinned are looked at again.
  if (acceptAgreeingRevisits(waiting)) {
    unoptimized_accepts_ = 0;
    for (int c : recoverHypotheses(true)) {
      // The pending clusters already bound for the joint test (placing groups among them) stay.
      if (std::find(joint.begin(), joint.end(), c) == joint.end()) sort_out(c, "recover");
    }
  }
  // Joint tests (realize / reverse) of the good set and the undecided clusters, which also fold
  // the clusters accepted since the last update into the map; while the good set grows, the
  // rejected clusters that now fit its map are recovered.
  for (int round = 0; round < params_.max_rounds; ++round) {
    if (joint.empty() && unoptimized_accepts_ < params_.incremental_map_update_every) return;
    const bool unoptimized = std::exchange(unoptimized_accepts_, 0) > 0;
    const bool placing = !placing_groups.empty();
    placing_groups.clear();
    // The online checks need the decision before the joint test, to undo it (a placing group
    // moves a session that nothing held: its increase says nothing). A joint test of the good
    // set alone (a map update) cannot grow it: no copy then.
    std::optional<DecisionState> before;
    double good_chi2_before = 0.0;
    if ((params_.online_increase_test || params_.online_scratch_check) && !placing &&
        !joint.empty()) {
      // The increase is the tested clusters' own: clusters accepted on the map's word since its
      // last optimization are folded into it first, or the fall of their own chi2 as the joint
      // test fits them would hide a group's excess.
      if (unoptimized) optimizeGoodMap();
      before = decisionState();
      good_chi2_before = goodSetChi2();
    }
    bool grew =
        realize(joint, params_.warm_start ? base_ : graph_.initialPoses(), "realize", true, true);
    if (grew && before && params_.online_increase_test &&
        undoIfIncreaseFails(*before, good_chi2_before)) {
      grew = false;
    }
    // The others are tested again without the groups a decision from scratch rejects.
    if (grew && before && params_.online_scratch_check && undoIfScratchRejects(*before, joint)) {
      continue;
    }
    joint.clear();
    // The joint test may have kept fewer of a placing group than tie a session.
    if (placing && holdLoosePlacements()) refreshGoodMap();
    if (!grew) return;
    admit(recoverHypotheses(true), "recover");
  }
}

}  // namespace rrr_graphslam::rrr
