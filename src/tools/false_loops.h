#pragma once
// rrr_slam_offline --false-loops F: false loop candidates injected into a SLAM run among the
// loop search's own, so that what RRR and the trimming of a lifelong map make of them can be
// measured on real logs (doc/lifelong.md). After each candidate of the loop search, one false
// candidate with probability F / (1 - F), so that about F of all candidates are false: it joins
// a node drawn uniformly among those at least min_node_separation older than the newest node to
// the newest node, says they lie close together (the random outliers of Suenderhauf and
// Protzel's generator, as scripts/add_outliers draws them: x, y ~ N(0, 0.3 m), theta ~ N(0, 10
// degrees)), and carries the information of the search's newest candidate. Seeded: the same log,
// parameters and seed inject the same loops.

#include <cmath>
#include <random>

#include "rrr_graphslam/frontend/laser_slam.h"

namespace rrr_graphslam::tools {

struct FalseLoopParams {
  double fraction = 0.0;  ///< of all candidates; 0 injects none
  unsigned seed = 1;
};

class FalseLoopInjector {
 public:
  explicit FalseLoopInjector(const FalseLoopParams& params)
      : params_(params), rng_(params.seed), odds_(params.fraction / (1.0 - params.fraction)) {}

  /// After slam.addScan(): one draw per candidate the loop search added since the last call.
  void afterScan(frontend::LaserSlam& slam) {
    const int searched = slam.stats().candidates - injected_;
    if (params_.fraction <= 0.0 || searched <= searched_) {
      searched_ = searched;
      return;
    }
    const auto& rrr = slam.rrr();
    const Eigen::Matrix3d information = rrr.candidate(rrr.numCandidates() - 1).information;
    const int newest = rrr.numNodes() - 1;
    const int oldest_allowed = newest - slam.params().loops.min_node_separation;
    std::bernoulli_distribution inject(std::min(1.0, odds_));
    std::normal_distribution<double> metres(0.0, 0.3);
    std::normal_distribution<double> radians(0.0, 10.0 * M_PI / 180.0);
    for (int k = searched_; k < searched; ++k) {
      if (oldest_allowed < 0 || !inject(rng_)) continue;
      std::uniform_int_distribution<int> node(0, oldest_allowed);
      const int from = node(rng_);
      const core::Pose2 z(metres(rng_), metres(rng_), core::normalizeAngle(radians(rng_)));
      if (slam.addCandidate(from, newest, z, information, frontend::LoopSource::kInjected)) {
        ++injected_;
      }
    }
    searched_ = searched;
  }

  int injected() const { return injected_; }

 private:
  FalseLoopParams params_;
  std::mt19937 rng_;
  double odds_;
  int searched_ = 0;  ///< the loop search's candidates seen so far
  int injected_ = 0;
};

}  // namespace rrr_graphslam::tools
