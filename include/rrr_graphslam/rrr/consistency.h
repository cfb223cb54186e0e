#pragma once
// The two consistency tests of RRR (Latif, Cadena, Neira, "Robust loop closing over time for
// pose graph SLAM", IJRR 2013).
//
// Degrees of freedom: every SE(2) loop link adds 3 residual dimensions to the odometry chain,
// which alone fits exactly. So a link has dof 3, a cluster 3 * links, a set of clusters
// 3 * all their links; the residual D^2 of a set is the optimized chi2 of odometry + those links.

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/rrr/linearized_tests.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

/// Optimized chi2 of odometry + some links: in total and per link.
struct LinkResiduals {
  double total_chi2 = 0.0;
  std::vector<double> link_chi2;  ///< in the order the links were given
};

/// Odometry + `links` on a reduced graph: only the nodes the links touch, joined by the odometry
/// between them compounded into one constraint (OdometryChain). Equal, to first order in the
/// odometry noise, to fullGraphResiduals at a small fraction of the cost.
LinkResiduals reducedGraphResiduals(const VerificationGraph& graph, const std::vector<int>& links,
                                    const core::OptimizerParams& params);

/// The slow, obvious version: the whole graph with exactly `links` switched on, optimized from the
/// initial poses. Leaves the graph's optimizer in that state.
LinkResiduals fullGraphResiduals(VerificationGraph& graph, const std::vector<int>& links);

/// A chi-square test as a decision states it: "D2_l 9.12 >= chi2(0.95, 3) 7.81". A statistic that
/// is not finite fails (and reads "nan" or "inf").
std::string chi2Test(const char* statistic, double value, double alpha, int dof);
/// A consistency index against its limit: "CI 1.52 >= 1".
std::string indexTest(const char* name, double index, double limit = 1.0);
/// What a reason adds about the optimization its statistic comes from: nothing when it
/// converged, else " (optimizer: max-iterations)" and the like.
std::string stopNote(core::StopReason stop);
/// Non-finite statistics count as failing every test: NaN becomes +infinity.
inline double failIfNotFinite(double statistic) {
  return statistic == statistic ? statistic : std::numeric_limits<double>::infinity();
}

struct IntraClusterResult {
  std::vector<int> kept;                 ///< links that survive, in the cluster's order
  std::vector<int> dropped;              ///< links removed, in removal order
  std::vector<std::string> why_dropped;  ///< per dropped link: the test it failed
  int optimizations = 0;
};

using ResidualFunction = std::function<LinkResiduals(const std::vector<int>& links)>;

/// Intra-cluster consistency (the paper's Algorithm 1): odometry + the cluster's links are
/// optimized; if D^2_G < chi2(alpha, dof_G), links with D^2_l >= chi2(alpha, 3) are dropped and
/// the rest kept; otherwise the cluster fails whole. With `worst_link_removal`
/// (RrrParams::intra_worst_link_removal) a failing cluster loses only its worst link and the rest
/// is tested again, so a cluster mixing true and false links keeps the true ones.
IntraClusterResult intraClusterConsistency(const std::vector<int>& cluster, double alpha,
                                           const ResidualFunction& residuals,
                                           bool worst_link_removal = true);

struct InterClusterResult {
  std::vector<int> consistent;           ///< cluster ids jointly consistent, in the given order
  std::vector<double> consistent_index;  ///< their consistency indices at the solution
  std::vector<int> removed;              ///< cluster ids removed, in removal order
  std::vector<std::string> why_removed;  ///< per removed cluster: the test of its round
  double chi2 = 0.0;                     ///< D^2_G of the consistent set's solution
  int dof = 0;                           ///< its degrees of freedom (3 per link)
  /// How the consistent set's optimization ended. Not converged: the tests were made at the
  /// poses it reached, whose chi2 is above the minimum's, so a pass still holds and a failure is
  /// conservative.
  core::StopReason stop = core::StopReason::kConverged;
  int optimizations = 0;
};

/// Inter-cluster consistency (the paper's Algorithm 2): optimizes odometry + the links of
/// `clusters` from `start`, and while the set is inconsistent (D^2_G >= chi2(alpha, dof_G), or
/// some cluster's consistency index D^2_C / chi2(alpha, dof_C) >= 1) removes the cluster with
/// the highest index, together with every cluster whose index is at least
/// `batch_fraction` * the highest (1.0 removes one at a time, as in the paper; removed clusters
/// get another chance in RRR's recover step). When only the joint test fails (every index below
/// 1), the paper's highest index names no culprit: a large false group that bends the map
/// toward itself fits it best of all, and the true clusters it pulls away went one by one. With
/// `conflict_removal` (RrrParams::conflict_removal) the cluster removed then is the one whose
/// removal the linearized test predicts to lower D^2_G most per degree of freedom
/// (leaveOneOutIndex), if any is above 1. Clusters listed in `kept_anyway` (sorted) are never
/// removed, only the others (the paper's hypotheses); the loop ends when nothing else can go. With
/// `restart` every round starts again from `start`, otherwise from the previous round's solution. A
/// non-finite index counts as infinite (the cluster goes). At most one round per cluster. On return
/// the graph's optimizer holds the solution of the consistent set.
InterClusterResult interClusterConsistency(VerificationGraph& graph,
                                           const std::vector<std::vector<int>>& cluster_links,
                                           const std::vector<int>& clusters,
                                           const std::vector<core::Pose2>& start, double alpha,
                                           double batch_fraction, bool restart = false,
                                           const std::vector<int>& kept_anyway = {},
                                           bool conflict_removal = false);

}  // namespace rrr_graphslam::rrr

namespace rrr_graphslam::rrr {

/// A map that gross outliers cannot bend: odometry + `links` optimized from `start` by iteratively
/// reweighted least squares with Dynamic Covariance Scaling weights (Agarwal et al., "Robust map
/// optimization using dynamic covariance scaling", ICRA 2013): a link with chi2 x gets its
/// information scaled by min(1, 2 phi / (phi + x))^2. phi starts above every residual and
/// shrinks to `phi` (graduated non-convexity), so a drifted start (ringCity) still closes its
/// loops; a start far from the first round's minimum (core::farFromMinimum) is replaced by LAGO's
/// estimate of it. RRR uses the map only to choose which clusters to test jointly first; every
/// decision is still a chi-square test. `prior_weights` (one per link, or empty for all 1) multiply
/// the DCS weights; links whose weight falls below 1e-4 are switched off until it rises again.
/// Weights are reset and exactly `links` are switched on on return.
/// With `graduated` false, phi is `phi` from the first round and `start` is kept however far it
/// is from the least-squares minimum: DCS as published, for a start that is already a map (the
/// last decision's), which the outliers' least squares would bend away from.
std::vector<core::Pose2> robustMap(VerificationGraph& graph, const std::vector<int>& links,
                                   const std::vector<core::Pose2>& start, double phi,
                                   int& optimizations,
                                   const std::vector<double>& prior_weights = {},
                                   bool graduated = true);

}  // namespace rrr_graphslam::rrr
