#pragma once
// RRR: Realizing, Reversing, Recovering (Latif, Cadena, Neira, "Robust loop closing over time for
// pose graph SLAM", IJRR 2013, Algorithm 3). Loop candidates are grouped into clusters; each
// cluster is checked on its own (intra-cluster consistency) when it is added; a decision then
//   realizes: the largest jointly consistent set of good + pending clusters becomes the good set
//             (inter-cluster consistency);
//   reverses: a good cluster that is no longer consistent with the others leaves the good set;
//   recovers: while the good set grows, rejected clusters that agree with its map get another
//             joint test.
// Batch RRR adds every cluster and decides once (decideFromScratch); incremental RRR
// (IncrementalRrr) adds clusters as the robot leaves them and decides after each
// (decideIncrementally), then once more from scratch at the end.
//
// Not thread-safe; one thread drives an Rrr and its VerificationGraph.

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/consistency.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

struct RrrParams {
  /// Confidence of every chi-square test; default 0.95 (the paper's).
  double alpha = 0.95;
  /// Clustering gap in nodes; default 0 = derived from the candidates (deriveClusterGap).
  int cluster_gap = 0;
  /// Incremental: re-optimize the good set after this many clusters were accepted without it;
  /// default 32.
  int incremental_map_update_every = 32;
  /// Incremental: when the robot passes a multiple of this many nodes, the clusters closed so far
  /// are decided from scratch (batch RRR over them) instead of incrementally. A false cluster
  /// that got into the good set online stays there, bends the map and makes every later joint
  /// test a long Levenberg-Marquardt run; the batch decision (robust map, leave-one-out check)
  /// takes it out. Default 1000; 0: never (until finish()).
  int incremental_rebatch_every = 1000;
  /// Incremental: joint tests start from the good set's last factorization, brought up to date
  /// by rank updates for the clusters switched on or off (OptimizerParams::factor_updates),
  /// instead of a fresh factorization each; default true.
  bool incremental_factor_updates = true;
  /// Incremental: joint tests stop when chi2 would drop by less than this fraction (the
  /// optimizer's relative_tolerance, 1e-6 by default, serves the final decision); default 1e-4,
  /// a thousandth of one link's test threshold on the largest graphs here.
  double incremental_relative_tolerance = 1e-4;
  /// Inter-cluster: also remove clusters whose consistency index is at least this fraction of the
  /// worst; default 0.5. 1.0 removes one cluster per optimization, as in the paper.
  double batch_removal_fraction = 0.5;
  /// Recover: retry a rejected cluster jointly when its consistency index against the good set's
  /// map, without moving any pose, is below this; default 10.
  double recover_gate = 10.0;
  /// Recover, far: a rejected cluster of at least this many links whose index against the good
  /// set's map is above recover_gate is still tested once per decision with the good set, from
  /// the good map, if its linearized joint test there (predicted index) is below recover_gate;
  /// it is accepted if all stay consistent without removing any and it raises the good set's
  /// chi2 by less than chi2(alpha, its dof). A drifted ring's closure (ringCity) disagrees with
  /// the open ring's map by far more than recover_gate, yet is many links strong. The leave-one-out
  /// check examines good clusters this large whatever their own index. Default 10 (0: never).
  int far_retry_min_links = 10;
  /// After a batch decision, links of good clusters that fail the per-link chi-square test at
  /// the good set's joint solution are dropped (Rrr::jointLinkCheck); default true.
  bool joint_link_check = true;
  /// Leave-one-out check: examine good clusters whose own consistency index is at least this,
  /// and those of far_retry_min_links links or more; default 0.1 (0 examines all).
  double loo_min_index = 0.1;
  /// Dynamic Covariance Scaling parameter of the robust map that orders batch decisions; default 1.
  double dcs_phi = 1.0;
  /// Realize/reverse/recover rounds per decision; default 50.
  int max_rounds = 50;
  /// Intra-cluster tests on the reduced graph (true) or the whole graph (false); default true.
  bool reduced_intra_graph = true;
  /// A cluster that fails its intra test as a whole is split into sets of pairwise consistent
  /// links (pairwise_consistency.h), each a cluster of its own; default true. False: the worst
  /// links are dropped from the whole until the rest passes.
  bool split_mixed_clusters = true;
  /// Optimizer settings for every test; default Gauss-Newton.
  core::OptimizerParams optimizer;
};

enum class Verdict : std::uint8_t { kAccepted, kRejected, kPending };
std::string toString(Verdict verdict);

/// Called with a stage name ("intra", "inter"), work done and total, for progress display.
using ProgressFunction = std::function<void(const char* stage, int done, int total)>;

class Rrr {
 public:
  Rrr(VerificationGraph& graph, const RrrParams& params);

  /// Runs the intra-cluster test on `members` (candidate indices), which become one cluster, or
  /// several when the whole fails and split_mixed_clusters is set. Returns how many.
  int addCluster(const std::vector<int>& members);
  /// The online step of incremental RRR, for clusters just added. A cluster that fits the good
  /// set's map without moving it (index < 1: the joint chi2 can then only be lower) is accepted
  /// and folded into the map at the next joint test; one whose linearized joint test (the chi2
  /// increase predicted from the map's marginal covariance) fails is rejected until the map grows
  /// (recover) or the final decision; the others get the joint test with optimization, which
  /// can also reverse earlier decisions. The map is re-optimized at the latest after
  /// incremental_map_update_every accepted clusters.
  void decideIncrementally();
  /// Every cluster that passed its intra test decided again from the initial estimate: the batch
  /// decision, independent of the order clusters arrived in. The clusters that agree with a robust
  /// (DCS) map are tested jointly first; the others go through the recover step.
  void decideFromScratch();

  Verdict verdict(int candidate) const;
  /// -1 while the candidate is in no cluster.
  int clusterOf(int candidate) const {
    const auto k = static_cast<std::size_t>(candidate);
    return k < cluster_of_.size() ? cluster_of_[k] : -1;
  }
  int numClusters() const { return static_cast<int>(clusters_.size()); }
  const std::vector<int>& clusterMembers(int cluster) const {
    return clusters_[static_cast<std::size_t>(cluster)].members;
  }
  /// Optimizations run so far (intra tests on reduced graphs included).
  int optimizations() const { return optimizations_; }
  const RrrParams& params() const { return params_; }
  /// Links of the good clusters that survived their intra test: the accepted loops.
  std::vector<int> acceptedCandidates() const;
  /// False once the candidate's cluster was tested and its intra-cluster test dropped it (alone or
  /// with its whole cluster); true otherwise.
  bool passedIntraTest(int candidate) const;
  /// True when the candidate passed its intra test and the last joint link check dropped it
  /// (its cluster stays good unless it lost every link).
  bool droppedByJointLinkCheck(int candidate) const;
  /// The map: poses of the good set's last solution, continued by odometry over the nodes added
  /// since (a new session's first node at its initial pose).
  std::vector<core::Pose2> mapEstimate() const;

  void setProgress(ProgressFunction progress) { progress_ = std::move(progress); }

 private:
  enum class Status : std::uint8_t { kPending, kGood, kRejected, kInconsistent };
  enum class OnlineVerdict : std::uint8_t { kFits, kDoesNotFit, kNeedsJointTest };
  struct Cluster {
    std::vector<int> members;
    std::vector<int> passed;  // after the intra test (kept_links_: and the joint link check)
    Status status = Status::kPending;
    int time_cluster = 0;  // the clustering's cluster it was split from (or is)
  };

  /// Makes `consistent` the good set; the other `tested` clusters are rejected. Returns true if
  /// a cluster became good that was not before.
  bool apply(const std::vector<int>& tested, const std::vector<int>& consistent);
  /// Extends the per-candidate and per-node state to what the graph holds now (online growth):
  /// a new node's map pose follows odometry from the last estimate.
  void syncWithGraph();
  /// One cluster of `members`, intra-tested; `whole` is their joint test's result if known.
  void addTestedCluster(const std::vector<int>& members, const LinkResiduals* whole);
  /// Recover, far (RrrParams::far_retry_min_links): the first large rejected cluster, largest
  /// first, not yet in `tried`, that passes the linearized joint test's screen and that the good
  /// set accepts as is, for less than its own chi2 threshold, becomes good; returns whether one
  /// did.
  bool recoverFar(std::vector<char>& tried);
  /// The joint test that realizes a batch decision starts from the robust map, where a region the
  /// good set constrains loosely can stay in a local minimum (City10000 + 1000 random-grouped:
  /// chi2 744 against 504, and 160 true links that do not fit it). The good set is optimized
  /// again from LAGO's estimate, which wins if its chi2 is lower by more than chi2(alpha, 3).
  void settleGoodMap();
  /// Appends to `poses` the nodes of the graph it lacks, following odometry.
  void extendByOdometry(std::vector<core::Pose2>& poses) const;
  std::vector<int> clustersWith(Status status) const;
  /// Links that make the robust map ordering a batch decision.
  std::vector<int> robustMapLinks(const std::vector<int>& pending) const;
  /// The robust map that orders a batch decision. Two are built: one with every link at full
  /// weight, and one in which each time cluster has one vote (its links share weight 1), so that
  /// false groups cut into many consistent pieces (random-grouped outliers) cannot outvote the
  /// true loops; the full-weight map still closes drifted loops that a few strong links carry
  /// (ringCity, CSAIL), where the one-vote map falls short. The map more pending links agree
  /// with wins: the larger consensus, as in RANSAC.
  std::vector<core::Pose2> robustOrderingMap(const std::vector<int>& pending,
                                             const std::vector<core::Pose2>& initial);
  struct ClusterLinearization;
  ClusterLinearization linearizeCluster(int cluster) const;
  OnlineVerdict checkAgainstMap(int cluster) const;
  /// decideIncrementally() after syncing with the graph.
  void decideAgainstMap();
  /// The good set optimized from base_, which becomes its solution (after a cluster or link
  /// left it).
  void optimizeGoodMap();
  /// The optimizer holds the good set at base_, factored there (one undamped optimization if
  /// the last factorization is of something else), so covariance() and predictedIndex() describe
  /// the good map.
  void factorGoodMap();
  /// Leave-one-out check of the good set: a good cluster whose removal would lower the chi2 by
  /// more than chi2(alpha, dof) (linearized: r^T (Sigma_C - J Sigma_map J^T)^-1 r, with the
  /// map's covariance including the cluster) conflicts with the rest even though the map bent
  /// far enough to give it a small residual; it is rejected. Only clusters whose own index is
  /// at least loo_min_index are examined, and the large ones (far_retry_min_links): a large
  /// cluster pulls the map onto itself, so its own residual says little (a self-consistent false
  /// group on ringCity: own index 0.05, leave-one-out index 1.1). Returns true if a cluster was
  /// rejected.
  bool leaveOneOutCheck();
  /// The intra test's link rule (a link with D^2_l >= chi2(alpha, 3) is dropped) applied again
  /// at the good set's joint solution (RrrParams::joint_link_check): a false link inside a true
  /// cluster can pass the cluster's own test, where the odometry between its ends bends to meet
  /// it, yet not the map all good clusters make. The worst link of each such cluster goes (those
  /// at least batch_removal_fraction of the worst of all), the map is optimized again, and so on.
  /// Returns true if a link was dropped.
  bool jointLinkCheck();
  /// Chi2 decrease predicted for removing a good cluster, over chi2(alpha, dof).
  double leaveOneOutIndex(int cluster) const;
  /// Chi2 increase predicted for adding a cluster to the good set (linearized at base_, with the
  /// optimizer's last factorization), over chi2(alpha, dof); none when no factor is usable (or
  /// the cluster kept no link).
  std::optional<double> predictedIndex(int cluster) const;
  /// At least far_retry_min_links kept links (the far retry and the leave-one-out check).
  bool largeCluster(int cluster) const;
  /// e^T Omega e of one candidate at fixed poses.
  double linkChi2(int candidate, const std::vector<core::Pose2>& poses) const;
  /// Consistency index of a cluster's kept links at fixed poses.
  double indexAt(int cluster, const std::vector<core::Pose2>& poses) const;
  void realizeReverseRecover(const std::vector<core::Pose2>& initial, bool robust_ordering);

  VerificationGraph& graph_;
  RrrParams params_;
  ResidualFunction residuals_;  // the intra test's optimization: reduced or whole graph
  std::vector<Cluster> clusters_;
  // Per cluster, the links that take part in the joint tests: those that passed the intra test,
  // less those the last joint link check dropped.
  std::vector<std::vector<int>> kept_links_;
  std::vector<int> cluster_of_;
  std::vector<core::Pose2> base_;   // solution of the good set
  std::vector<int> previous_good_;  // good set before the current joint test
  int time_clusters_ = 0;           // addCluster calls so far
  int unoptimized_accepts_ = 0;     // accepted by decideIncrementally, not yet in the map
  int optimizations_ = 0;
  ProgressFunction progress_;
};

struct RrrSummary {
  int candidates = 0;
  int clusters = 0;
  int cluster_gap = 0;
  int accepted = 0;
  int rejected = 0;
  int optimizations = 0;
  double time_sec = 0.0;
};

/// Ends of every candidate of `graph`, for clustering.
std::vector<CandidateEnds> candidateEnds(const VerificationGraph& graph);

/// Per-candidate verdicts and clusters of `rrr`, counted into `summary` (whose `candidates`
/// must be set) with the optimizations run and the time since `start`.
void collectVerdicts(const Rrr& rrr, std::chrono::steady_clock::time_point start,
                     std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                     RrrSummary& summary);

/// Batch RRR over every candidate of `graph`. On return graph.optimizer() holds odometry +
/// the accepted loops, optimized; `verdicts` and `cluster_of` have one entry per candidate.
RrrSummary runBatchRrr(VerificationGraph& graph, const RrrParams& params,
                       std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                       const ProgressFunction& progress = {});

}  // namespace rrr_graphslam::rrr
