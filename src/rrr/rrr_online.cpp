// The online step of incremental RRR (Latif, Cadena, Neira, IROS 2012): clusters just closed are
// decided against the good set's map, and jointly with the good set when the map cannot tell.

#include <algorithm>
#include <cstdio>
#include <optional>
#include <utility>

#include "rrr_graphslam/rrr/linearized_tests.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {
namespace {

std::string ratioText(double ratio) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", ratio);
  return text;
}

}  // namespace

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
  const std::vector<int>& kept = kept_links_[static_cast<std::size_t>(cluster)];
  if (params_.online_untestable_ratio > 0.0 && kept.size() == 1) {
    const std::optional<double> ratio = mapUncertaintyRatio(graph_, kept, base_);
    if (ratio && *ratio > params_.online_untestable_ratio) {
      statistic = *ratio;
      return OnlineVerdict::kUntestable;
    }
  }
  return OnlineVerdict::kNeedsJointTest;
}

void Rrr::decideAgainstMap() {
  std::vector<int> joint;
  std::vector<int> placing_groups;  // in `joint`: groups placing an untied session
  std::vector<int> waiting;         // one-link clusters the map cannot test yet
  int accepted_on_map = 0;          // clusters accepted here on the map's word (not in its factor)
  auto sort_out = [&](int c, const char* step) {
    // A one-link cluster is judged by how well the map knows where it should lie, from the good
    // set's factor (made here if the last joint test left none usable).
    if (params_.online_untestable_ratio > 0.0 &&
        kept_links_[static_cast<std::size_t>(c)].size() == 1 &&
        !graph_.optimizer().covarianceAvailable()) {
      factorGoodMap();
    }
    double statistic = 0.0;
    switch (checkAgainstMap(c, statistic)) {
      case OnlineVerdict::kFits:
        setStatus(c, Status::kGood,
                  std::string(step) + ": " + indexTest("CI", statistic) + " at the good map");
        ++unoptimized_accepts_;
        ++accepted_on_map;
        break;
      case OnlineVerdict::kDoesNotFit:
        setStatus(c, Status::kRejected,
                  std::string(step) + ": linearized joint " + indexTest("index", statistic));
        break;
      case OnlineVerdict::kNeedsJointTest:
        joint.push_back(c);
        break;
      case OnlineVerdict::kUntestable:
        setStatus(c, Status::kPending,
                  std::string(step) + ": waits: the map leaves " + ratioText(statistic) +
                      " times its own uncertainty open");
        waiting.push_back(c);
        break;
    }
  };
  // Clusters joining a session not yet tied to the map wait for a group of them that places it
  // (placement_min_spread_m): the group is tested jointly, the others once the session is tied.
  auto admit = [&](std::vector<int> clusters, const char* step) {
    if (params_.placement_min_spread_m > 0.0) {
      const std::vector<int> waiting = clustersWith(Status::kUnplaced);
      clusters.insert(clusters.end(), waiting.begin(), waiting.end());
      const std::vector<int> groups = takePlacingClusters(clusters);
      joint.insert(joint.end(), groups.begin(), groups.end());
      placing_groups.insert(placing_groups.end(), groups.begin(), groups.end());
    }
    for (int c : clusters) sort_out(c, step);
  };
  admit(clustersWith(Status::kPending), "online");
  // Clusters just accepted on the map's word may hold the path a waiting link hangs from: the map
  // takes them in and the waiting links are checked again (after a joint test that grows the good
  // set, the recover step below does it).
  if (!waiting.empty() && accepted_on_map > 0) {
    optimizeGoodMap();
    factorGoodMap();
    unoptimized_accepts_ = 0;
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
    if (placing && holdLoosePlacements()) {
      optimizeGoodMap();
      factorGoodMap();
    }
    if (!grew) return;
    admit(recoverHypotheses(true), "recover");
  }
}

}  // namespace rrr_graphslam::rrr
