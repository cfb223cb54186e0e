#pragma once
// RRR: Realizing, Reversing, Recovering (Latif, Cadena, Neira, "Robust loop closing over time for
// pose graph SLAM", IJRR 2013). Loop candidates are grouped into clusters; each cluster is
// checked on its own when it is added (Algorithm 1, intra-cluster consistency); a decision
// (Algorithm 3) then
//   realizes: the hypotheses that pass the joint test with the good set (Algorithm 2,
//             inter-cluster consistency) join it;
//   reverses: a good cluster that is no longer consistent with the others leaves the good set;
//   recovers: while the good set grows, rejected clusters become hypotheses again.
// decideFromScratch() is Algorithm 3, one function in the paper's words; each addition to it
// is a step of its own with a switch in RrrParams (rrr_params.h, doc/rrr_extensions.md), in
// rrr_steps.cpp. Incremental RRR (IncrementalRrr) adds clusters as the robot leaves them and
// decides each against the good set's map (decideIncrementally, rrr_online.cpp), then once more
// from scratch at the end.
//
// Every decision records its reason where it is made: the step, and its statistic against its
// threshold (reason()).
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
#include "rrr_graphslam/rrr/rrr_params.h"
#include "rrr_graphslam/rrr/session_placement.h"
#include "rrr_graphslam/rrr/step_profile.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

enum class Verdict : std::uint8_t { kAccepted, kRejected, kPending };
std::string toString(Verdict verdict);

/// Called with a stage name ("intra", "inter"), work done and total, for progress display.
using ProgressFunction = std::function<void(const char* stage, int done, int total)>;

class Rrr {
 public:
  /// Throws std::invalid_argument for parameters out of range (validate()).
  Rrr(VerificationGraph& graph, const RrrParams& params);

  /// Algorithm 1: the intra-cluster test of `members` (candidate indices), which become one
  /// cluster, or several when the whole fails and split_mixed_clusters is set. Returns how many.
  int addCluster(const std::vector<int>& members);
  /// Algorithm 3 over every cluster added so far, from the initial estimate: the batch decision,
  /// independent of the order clusters arrived in.
  void decideFromScratch();
  /// The online step of incremental RRR, for clusters just added: each is decided against the
  /// good set's map (online_map_check) or in a joint test with the good set, which can also
  /// reverse earlier decisions; while the good set grows, rejected clusters are recovered.
  void decideIncrementally();

  Verdict verdict(int candidate) const;
  /// Why the candidate has its verdict: the step that decided it and its statistic against the
  /// threshold, e.g. "intra-cluster: D2_l 9.12 >= chi2(0.95, 3) 7.815".
  std::string reason(int candidate) const;
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
  /// After the last decision (placement_min_spread_m): the clusters still waiting for their
  /// session to be placed are rejected, with the reason they waited.
  void rejectUnplaced();
  /// The map: poses of the good set's last solution, continued by odometry over the nodes added
  /// since (a new session's first node at its initial pose).
  std::vector<core::Pose2> mapEstimate() const;
  /// The previous map for the next decideFromScratch(), instead of the last decision's solution:
  /// a map that decisions made before this Rrr existed (a loaded map's saved poses), one pose per
  /// node of the graph now, in the graph's gauge (node 0 where the initial estimate has it). It
  /// places sessions and, in a graph of several sessions, is one of the robust ordering's maps.
  /// Throws std::invalid_argument for a size other than the graph's node count.
  void seedPreviousMap(std::vector<core::Pose2> map);

  void setProgress(ProgressFunction progress) { progress_ = std::move(progress); }
  /// Where the time of the decisions so far went, step by step (StepProfile).
  const std::vector<StepCost>& stepCosts() const { return profile_.steps(); }

 private:
  // One named step of the profile, for the scope it lives in.
  class Step {
   public:
    Step(const Rrr& rrr, const char* name) : rrr_(rrr) {
      rrr_.profile_.enter(name, rrr_.profileCounters());
    }
    ~Step() { rrr_.profile_.leave(rrr_.profileCounters()); }
    Step(const Step&) = delete;
    Step& operator=(const Step&) = delete;

   private:
    const Rrr& rrr_;
  };
  StepProfile::Counters profileCounters() const {
    return {optimizations_, graph_.optimizer().factorizationWork()};
  }

  // kUnplaced: joins a session not tied to the map, which no group of clusters places yet
  // (placement_min_spread_m); undecided, and in no joint test until then.
  enum class Status : std::uint8_t { kPending, kGood, kRejected, kInconsistent, kUnplaced };
  enum class OnlineVerdict : std::uint8_t { kFits, kDoesNotFit, kNeedsJointTest, kUntestable };
  struct Cluster {
    std::vector<int> members;
    std::vector<int> passed;  // after the intra test (kept_links_: and the joint link check)
    Status status = Status::kPending;
    int time_cluster = 0;  // the clustering's cluster it was split from (or is)
    std::string reason;    // of its status
  };

  // --- The paper's steps (rrr.cpp).
  /// Algorithm 3 once: from the intra results to the final checks. `placement_map` is the
  /// previous map placeSessions() measures agreement on; `ordering_map`, if given, is the robust
  /// ordering's third contender. Returns true if that contender ordered the work.
  bool decideOnce(const std::vector<core::Pose2>* placement_map,
                  const std::vector<core::Pose2>* ordering_map);
  /// What a decision changes, to run it twice and keep one (decideFromScratch).
  struct DecisionState {
    std::vector<Cluster> clusters;
    std::vector<std::vector<int>> kept_links;
    std::vector<std::string> link_reason;
    std::vector<core::Pose2> base;
    bool base_is_solution = false;
    std::vector<int> previous_good, last_removed;
    int unoptimized_accepts = 0;
  };
  DecisionState decisionState() const;
  void restoreDecisionState(DecisionState state);
  /// Algorithm 3's input: every cluster that passed its intra test is a hypothesis again, with
  /// every link that passed it; the good and reject sets are empty; the map is the initial one.
  void startFromIntraResults();
  /// The hypotheses a joint test takes: those with a link consistent (D^2_l < chi2(alpha, 3)) with
  /// the map of odometry + all the hypotheses' links, optimized from the initial estimate.
  std::vector<int> preselect(const std::vector<int>& hypotheses);
  /// Realize (and reverse): Algorithm 2 over the good set and `hypotheses`, from `start`; the
  /// jointly consistent clusters become the good set and the others are rejected (a good one is
  /// reversed). Returns true if the good set gained a cluster. With `factor_at_solution`, the
  /// optimizer ends holding an undamped factorization of the good map (for the online gate).
  bool realize(const std::vector<int>& hypotheses, const std::vector<core::Pose2>& start,
               const char* step, bool restart, bool factor_at_solution = false);
  /// Recover: the hypotheses of the next round, when the good set grew the rejected clusters
  /// that become hypotheses again with those still hypotheses. The paper: the reject set is
  /// cleared but for this round's removals (those clusters are hypotheses, kPending, again until
  /// a joint test removes them); with a finite recover_gate, the rejected clusters whose index at
  /// the good map is below it are retried without leaving the reject set.
  std::vector<int> recoverHypotheses(bool grew);
  /// Makes `inter.consistent` the good set; the other `tested` clusters are rejected, each with
  /// its reason. Returns true if a cluster became good that was not before.
  bool apply(const std::vector<int>& tested, const InterClusterResult& inter, const char* step);
  /// One cluster of `members`, intra-tested; `whole` is their joint test's result if known.
  void addTestedCluster(const std::vector<int>& members, const LinkResiduals* whole);

  // --- Additions (rrr_steps.cpp), each switched by its RrrParams field.
  /// robust_ordering: the hypotheses that agree with a robust map (robustOrderingMap), which
  /// becomes `start`; the others are rejected and left to the recover step. `previous_won` says
  /// whether the map built from `previous_map` won and orders the work.
  std::vector<int> orderByRobustMap(const std::vector<int>& hypotheses,
                                    std::vector<core::Pose2>& start,
                                    const std::vector<core::Pose2>* previous_map,
                                    bool& previous_won);
  /// The robust map that orders a batch decision. Two are built from `initial`: one with every
  /// link at full weight, and one in which each time cluster has one vote (its links share
  /// weight 1), so that false groups cut into many consistent pieces (random-grouped outliers)
  /// cannot outvote the true loops; the full-weight map still closes drifted loops that a few
  /// strong links carry (ringCity, CSAIL), where the one-vote map falls short. With a
  /// `previous_map` (seeded or the last decision's, given when the graph holds several
  /// sessions) and the full-weight map outvoted, a third:
  /// DCS from it without graduation, which keeps the basin a decision found when the outliers'
  /// least squares would leave it (many sessions of one building, each adding the same aliased
  /// places). The map more pending links agree with wins: the larger consensus, as in RANSAC.
  std::vector<core::Pose2> robustOrderingMap(const std::vector<int>& pending,
                                             const std::vector<core::Pose2>& initial,
                                             const std::vector<core::Pose2>* previous_map,
                                             bool& previous_won);
  /// place_sessions: `initial` with each session after the first moved rigidly so that the first
  /// kept link of the largest cluster joining it to the sessions placed so far holds exactly
  /// (sessions no cluster reaches stay where they are). Only a start: every cluster is tested
  /// from it as from the odometry.
  /// With placement_min_spread_m, a session is placed only by a group of agreeing clusters
  /// (session_placement.h); `placed_sessions` (if given) says per session whether it was.
  /// The agreement test measures the map side on `good_map` if given (a decision's solution),
  /// otherwise on `initial` with the map's odometry covariance.
  std::vector<core::Pose2> placeSessions(const std::vector<core::Pose2>& initial,
                                         std::vector<char>* placed_sessions = nullptr,
                                         const std::vector<core::Pose2>* good_map = nullptr) const;
  /// After a decision that started from placeSessions(): the sessions no good cluster joins to
  /// the first one's go back to their own odometry frame in the map (a rejected cluster placed
  /// them only to be tested).
  void unplaceLooseSessions();
  /// Links that make the robust map ordering a batch decision.
  std::vector<int> robustMapLinks(const std::vector<int>& pending) const;
  /// settle_good_map: the joint test that realizes a batch decision starts from the robust map,
  /// where a region the good set constrains loosely can stay in a local minimum. The good set is
  /// optimized again from LAGO's estimate, which wins if its chi2 is lower by more than
  /// chi2(alpha, 3).
  void settleGoodMap();
  /// far_retry_min_links: the first large rejected cluster, largest first, not yet in `tried`,
  /// that passes the linearized joint test's screen and that the good set accepts as is, for
  /// less than its own chi2 threshold, becomes good; returns whether one did.
  bool recoverFar(std::vector<char>& tried);
  /// leave_one_out_check: a good cluster whose removal would lower the chi2 by more than
  /// chi2(alpha, dof) (linearized: r^T (Sigma_C - J Sigma_map J^T)^-1 r, with the map's covariance
  /// including the cluster) conflicts with the rest even though the map bent far enough to give
  /// it a small residual; it is rejected. Only clusters whose own index is at least loo_min_index
  /// are examined, and the large ones (far_retry_min_links): a large cluster pulls the map onto
  /// itself, so its own residual says little. Returns true if a cluster was rejected.
  bool leaveOneOutCheck();
  /// loo_joint_min_index: the examined clusters whose leave-one-out `index` is at least it, left
  /// out together (their links as one set); if that fails, the one of the highest own index is
  /// rejected and leaveOneOutCheck() runs again. Returns true if a cluster was rejected.
  bool jointLeaveOut(const std::vector<int>& examined, const std::vector<double>& index);
  /// joint_link_check: the intra test's link rule (D^2_l >= chi2(alpha, 3) is dropped) applied
  /// again at the good set's joint solution: a false link inside a true cluster can pass the
  /// cluster's own test, where the odometry between its ends bends to meet it, yet not the map
  /// all good clusters make. The worst link of each such cluster goes (those at least
  /// batch_removal_fraction of the worst of all), the map is optimized again, and so on. Returns
  /// true if a link was dropped.
  bool jointLinkCheck();

  // --- placement_min_spread_m (rrr_placement.cpp).
  /// Per node, the set of sessions (trusted components) the good clusters join its session to,
  /// as one id: two nodes share it when accepted loops tie their sessions together.
  std::vector<std::size_t> joinedSessions() const;
  /// Takes out of `pending` the clusters that join a session not tied to the map (by good
  /// clusters) to anything: each such session's largest agreeing group of clusters joining it to
  /// the map is returned (status pending) when its session ends lie placement_min_spread_m
  /// apart; the others wait (kUnplaced, with the group's size and spread as reason).
  std::vector<int> takePlacingClusters(std::vector<int>& pending);
  /// Whether a group of agreeing clusters whose session ends lie `spread_m` apart places its
  /// session: two clusters or more, placement_min_spread_m apart, placement_min_ratio times its
  /// rival's clusters.
  bool groupPlaces(const PlacementGroup& group, double spread_m) const;
  /// How far apart along a session it saw `clusters`: spread() at `poses` over every kept link's
  /// end in the session (`in_session`), not only the first links'.
  double keptLinksSpread(const std::vector<int>& clusters, const std::vector<core::Pose2>& poses,
                         const std::function<bool(int)>& in_session) const;
  /// The group of `links` that places their session (largestAgreeingGroup at `poses`; with
  /// placement_wider_reading, preferWiderReading), its spread_m by `stretch` (m over a set of
  /// members).
  PlacementGroup placingGroup(const std::vector<core::Pose2>& poses,
                              const std::vector<JoiningLink>& links, bool map_exact,
                              const std::function<double(const std::vector<int>&)>& stretch) const;
  /// After a batch decision: a session the good clusters join to the others only at places
  /// closer than placement_min_spread_m has those clusters wait (kUnplaced) and goes back to its
  /// own frame; repeated while a session is let go. Returns true if a cluster was.
  bool holdLoosePlacements();
  /// Before a batch decision: the clusters with an end in a session placeSessions() could not
  /// place wait (kUnplaced) instead of taking part.
  void holdUnplacedSessions(const std::vector<char>& placed_sessions);

  // --- Incremental (rrr_online.cpp).
  OnlineVerdict checkAgainstMap(int cluster, double& statistic) const;
  /// online_untestable_ratio applies: on, both ends in one session, and one kept link or a
  /// revisit within its wait (online_group_wait_nodes).
  bool mayWaitForTheMap(int cluster) const;
  /// online_group_wait_nodes: the waiting clusters of several links tested jointly with the good
  /// set; kept when at least two of them pass and their increase fits, else undone. Returns true
  /// if they were kept.
  bool acceptAgreeingRevisits(const std::vector<int>& waiting);
  /// The good set optimized (the clusters accepted on the map's word folded in) and factored.
  void refreshGoodMap();
  /// decideIncrementally() after syncing with the graph.
  void decideAgainstMap();

  // --- Shared pieces (rrr_steps.cpp).
  /// Extends the per-candidate and per-node state to what the graph holds now (online growth):
  /// a new node's map pose follows odometry from the last estimate.
  void syncWithGraph();
  std::vector<int> clustersWith(Status status) const;
  void setStatus(int cluster, Status status, std::string reason);
  /// The good set optimized from base_, which becomes its solution (after a cluster or link
  /// left it).
  void optimizeGoodMap();
  /// The optimizer holds the good set at base_, factored there (one undamped optimization if
  /// the last factorization is of something else), so covariance() and predictedIndex() describe
  /// the good map.
  void factorGoodMap();
  /// The optimizer holding the good set's map: the accepted links switched on, the poses base_.
  void holdGoodMap();
  /// D2_G of the good set at base_: the chi2 of the trusted constraints and the accepted links
  /// above the trusted constraints' own optimum.
  double goodSetChi2() const;
  /// online_increase_test after a joint test that grew the good set from `before` (whose D2_G
  /// was `good_chi2_before`): if the clusters it added raised D2_G by chi2(alpha, 3 x their
  /// links) or more, `before` is restored and they are rejected. Returns whether it undid.
  bool undoIfIncreaseFails(DecisionState& before, double good_chi2_before);
  /// The clusters good now that were not in `before`.
  std::vector<int> addedSince(const DecisionState& before) const;
  /// online_scratch_check: the clusters of two links or more among `added` (good now) that a
  /// decision from scratch of every closed cluster, made now, rejects, each with its reason
  /// there; none in a graph of several sessions. The decision state is left as it was (the
  /// optimizer holding the good map, factored).
  std::vector<std::pair<int, std::string>> rejectedFromScratch(const std::vector<int>& added);
  /// Rejects them ("STEP: a decision from scratch rejects it (its reason)").
  void rejectAsFromScratch(const std::vector<std::pair<int, std::string>>& rejected,
                           const char* step);
  /// online_scratch_check after a joint test that grew the good set from `before`: if a decision
  /// from scratch rejects a group it added, `before` is restored (moved from), those groups are
  /// rejected and removed from `tested`. Returns whether it undid.
  bool undoIfScratchRejects(DecisionState& before, std::vector<int>& tested);
  /// A rise of D2_G by `increase` from `links` added links stays below chi2(alpha, 3 x links):
  /// the test of an innovation against its own degrees of freedom (far retry, online tests).
  bool increaseFits(double increase, int links) const;
  /// rrr::predictedIndex of a cluster's kept links at base_.
  std::optional<double> predictedIndex(int cluster) const;
  /// At least far_retry_min_links kept links (the far retry and the leave-one-out check).
  bool largeCluster(int cluster) const;
  /// e^T Omega e of one candidate at fixed poses.
  double linkChi2(int candidate, const std::vector<core::Pose2>& poses) const;
  /// Consistency index of a cluster's kept links at fixed poses.
  double indexAt(int cluster, const std::vector<core::Pose2>& poses) const;

  VerificationGraph& graph_;
  RrrParams params_;
  ResidualFunction residuals_;  // the intra test's optimization: reduced or whole graph
  std::vector<Cluster> clusters_;
  // Per cluster, the links that take part in the joint tests: those that passed the intra test,
  // less those the last joint link check dropped.
  std::vector<std::vector<int>> kept_links_;
  std::vector<int> cluster_of_;
  std::vector<std::string> link_reason_;  // per candidate dropped by a link test: why
  std::vector<core::Pose2> base_;         // solution of the good set
  bool base_is_solution_ = false;         // false until a decision optimized base_
  std::vector<core::Pose2> seeded_map_;   // seedPreviousMap(), until the next batch decision
  std::vector<int> previous_good_;        // good set before the current joint test
  std::vector<int> last_removed_;         // clusters the last joint test rejected
  int time_clusters_ = 0;                 // addCluster calls so far
  int unoptimized_accepts_ = 0;           // accepted by decideIncrementally, not yet in the map
  // The waiting revisits and the good set of acceptAgreeingRevisits' last undone test: the same
  // test is not made again.
  std::vector<int> revisits_tried_, good_when_tried_;
  int optimizations_ = 0;
  ProgressFunction progress_;
  mutable StepProfile profile_;  // instrumentation: const steps are profiled too
};

struct RrrSummary {
  int candidates = 0;
  int clusters = 0;
  int cluster_gap = 0;
  int accepted = 0;
  int rejected = 0;
  int optimizations = 0;
  double time_sec = 0.0;
  std::vector<StepCost> steps;  ///< where time_sec went (Rrr::stepCosts)
};

/// Ends of every candidate of `graph`, for clustering.
std::vector<CandidateEnds> candidateEnds(const VerificationGraph& graph);
/// params.cluster_gap, or when it is 0 the gap derived from the candidates (deriveClusterGap).
int clusterGapFor(const RrrParams& params, const std::vector<CandidateEnds>& ends);

/// Per-candidate verdicts, clusters (and reasons, if given) of `rrr`, counted into `summary`
/// (whose `candidates` must be set) with the optimizations run and the time since `start`.
void collectVerdicts(const Rrr& rrr, std::chrono::steady_clock::time_point start,
                     std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                     RrrSummary& summary, std::vector<std::string>* reasons = nullptr);

/// Batch RRR over every candidate of `graph`. On return graph.optimizer() holds odometry +
/// the accepted loops, optimized; `verdicts` and `cluster_of` have one entry per candidate.
RrrSummary runBatchRrr(VerificationGraph& graph, const RrrParams& params,
                       std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                       const ProgressFunction& progress = {},
                       std::vector<std::string>* reasons = nullptr);

}  // namespace rrr_graphslam::rrr
