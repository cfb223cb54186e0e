// The online step of incremental RRR (Latif, Cadena, Neira, IROS 2012): clusters just closed are
// decided against the good set's map, and jointly with the good set when the map cannot tell.

#include <algorithm>
#include <optional>
#include <utility>

#include "rrr_graphslam/rrr/linearized_tests.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {

void Rrr::decideIncrementally() {
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
  if (params_.online_untestable_ratio <= 0.0 || kept.size() != 1) return false;
  // A link to another session is the placement rules' (a session not yet tied hangs from nothing).
  const LoopCandidate& link = graph_.candidate(kept.front());
  return graph_.chain().sameSession(link.from, link.to);
}

void Rrr::refreshGoodMap() {
  optimizeGoodMap();
  factorGoodMap();
  unoptimized_accepts_ = 0;
}

void Rrr::decideAgainstMap() {
  std::vector<int> joint;
  std::vector<int> placing_groups;  // in `joint`: groups placing an untied session
  std::vector<int> waiting;         // one-link clusters the map cannot test yet
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
  // Joint tests (realize / reverse) of the good set and the undecided clusters, which also fold
  // the clusters accepted since the last update into the map; while the good set grows, the
  // rejected clusters that now fit its map are recovered.
  for (int round = 0; round < params_.max_rounds; ++round) {
    if (joint.empty() && unoptimized_accepts_ < params_.incremental_map_update_every) return;
    unoptimized_accepts_ = 0;
    const bool placing = !placing_groups.empty();
    placing_groups.clear();
    bool grew =
        realize(joint, params_.warm_start ? base_ : graph_.initialPoses(), "realize", true, true);
    joint.clear();
    // The joint test may have kept fewer of a placing group than tie a session.
    if (placing && holdLoosePlacements()) refreshGoodMap();
    if (!grew) return;
    admit(recoverHypotheses(true), "recover");
  }
}

}  // namespace rrr_graphslam::rrr
