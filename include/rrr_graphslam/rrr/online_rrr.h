#pragma once
// A pose graph under incremental RRR, fed one constraint at a time by a robot or a replay: the
// ROS-free half of the nodelet (src/ros is only the adapter around it) and what the SLAM front
// end hands its loop candidates to.
//
// Node ids are the caller's and must increase. Sequential (odometry) constraints join the newest
// node to the next id and create it at its pose in the odometry frame; a constraint from an
// unknown id starts a new session (multi-session maps: a session joins the others only through
// accepted loops). Loop candidates may name nodes that have not arrived yet (odometry and
// candidates often travel on different channels): they wait until those nodes exist.
//
// Every call that changes a verdict records a DecisionChange; takeChanges() hands them over once.
// Bad input throws std::invalid_argument naming the field (from_id, to_id, measurement.x, ...,
// information) and leaves the graph as it was. Not thread-safe: one thread owns an OnlineRrr.

#include <atomic>
#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/rrr/decisions_io.h"
#include "rrr_graphslam/rrr/online_decider.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/verification_graph.h"
#include "rrr_graphslam/rrr/verifier_choice.h"

namespace rrr_graphslam::rrr {

struct OnlineRrrParams {
  /// RRR settings; rrr.cluster_gap must be positive (online there are no candidates yet to derive
  /// it from); default 10 nodes.
  RrrParams rrr = [] {
    RrrParams p;
    p.cluster_gap = 10;
    return p;
  }();
  /// Loop candidates waiting for nodes that have not arrived, at most; default 10000.
  int max_waiting_candidates = 10000;
  /// Who decides (online_decider.h): RRR (default), or PCM, SCGP or GNC to compare, each
  /// deciding the closed clusters' candidates again whenever a cluster closes.
  VerifierChoice verifier;
};

/// rrr::validate, and cluster_gap > 0, max_waiting_candidates >= 0 and the verifier's settings
/// (std::invalid_argument).
void validate(const OnlineRrrParams& params);

/// One verdict that changed (or a candidate that arrived: previous == verdict == kPending).
struct DecisionChange {
  int candidate;  ///< arrival index
  core::PoseGraph::NodeId from;
  core::PoseGraph::NodeId to;
  int cluster;  ///< -1 while the candidate's cluster is open
  Verdict verdict;
  Verdict previous;
  std::string reason;  ///< the step of RRR that decided, and its statistic (Rrr::reason)
};

/// Counts for status displays.
struct OnlineRrrStatus {
  int nodes = 0;
  int sessions = 0;
  int candidates = 0;
  int marginal_edges = 0;
  int dense_factors = 0;  ///< dense factors in the graph (lifelong trimming, sparsification dense)
  int waiting_candidates = 0;  ///< naming nodes not arrived yet
  int clusters = 0;            ///< closed
  int open_clusters = 0;
  int accepted = 0;
  int rejected = 0;
  int pending = 0;
  int optimizations = 0;
};

class OnlineRrr {
 public:
  using NodeId = core::PoseGraph::NodeId;
  enum class CandidateStatus { kAdded, kWaiting };

  /// Throws std::invalid_argument for invalid parameters.
  explicit OnlineRrr(const OnlineRrrParams& params = {});
  OnlineRrr(const OnlineRrr&) = delete;
  OnlineRrr& operator=(const OnlineRrr&) = delete;

  /// A graph saved by save() (or any g2o/TORO graph): nodes at their file poses, odometry and
  /// candidates replayed in node order, then every cluster decided (finish()); the changes
  /// report every candidate's verdict. New nodes must have larger ids than the file's.
  /// With `keep_open_clusters` (a graph replayed to go on as it was: lifelong online trimming)
  /// the clusters still open at the last node stay open and their candidates pending; the closed
  /// ones are decided from scratch.
  /// `previous_map` (empty, or one pose per node in the order of graph.nodeIds(), in the graph's
  /// gauge): where the decisions that made the graph put its nodes (a saved map's poses, while
  /// the graph's own poses are the odometry frames the replay starts from); the decision starts
  /// from it where it can (OnlineDecider::seedPreviousMap).
  static std::unique_ptr<OnlineRrr> fromPoseGraph(const core::PoseGraph& graph,
                                                  const OnlineRrrParams& params = {},
                                                  bool keep_open_clusters = false,
                                                  std::vector<core::Pose2> previous_map = {});

  /// Holds every node it has now where it is (localization against a loaded map that must not
  /// change): they leave the optimization's variables, and the nodes added later are placed
  /// against them. Call it before any loop candidate names a node.
  void fixNodes();

  /// Starts a session with node `id` at `odom_pose` (its pose in the odometry frame).
  void startSession(NodeId id, const core::Pose2& odom_pose);
  /// Sequential constraint: `measurement` is the pose of node `to` in the frame of node `from`.
  /// `from` must be the newest node and `to` == from + 1, which is created; if `from` is unknown
  /// and newer than every node, it first starts a session at the origin.
  void addOdometry(NodeId from, NodeId to, const core::Pose2& measurement,
                   const Eigen::Matrix3d& information);
  /// A loop candidate (pose of `to` in `from`'s frame). kWaiting when an end has not arrived.
  /// Rejects unknown old ids, self-loops, consecutive ids of one session (that is odometry) and
  /// duplicates (same ends and measurement as an earlier candidate).
  CandidateStatus addCandidate(NodeId from, NodeId to, const core::Pose2& measurement,
                               const Eigen::Matrix3d& information);

  /// A marginal constraint (core::EdgeKind::kMarginal: what lifelong trimming left of removed
  /// nodes' constraints) between two existing nodes, trusted like odometry: always active and
  /// never decided. Throws std::invalid_argument for unknown ids, a self-loop or a bad
  /// measurement or information.
  void addMarginal(NodeId from, NodeId to, const core::Pose2& measurement,
                   const Eigen::Matrix3d& information);

  /// A dense factor (core/dense_factor.h: the exact marginal a `dense` trim leaves) over existing
  /// nodes (its own ids), trusted like a marginal constraint. Throws std::invalid_argument for an
  /// unknown id or a factor with core::denseFactorProblem().
  void addDenseFactor(const core::DenseFactor& factor);

  /// Every optimization checks `*flag` and stops (kCancelled) once it is raised, so that a long
  /// decision ends within a step; the verdicts reached meanwhile are not to be trusted: raise it
  /// only to throw this graph away (a reset, a shutdown). nullptr (default): never cancelled.
  void setCancelFlag(const std::atomic<bool>* flag) { graph_.optimizer().setCancelFlag(flag); }

  /// Closes and decides now the open clusters joining the session whose first node is
  /// `session_first` to the earlier sessions. Only for a caller that proposes no candidate
  /// joining them for more than cluster_gap nodes from now (a relocalization search that rests):
  /// the clusters stay those cluster_gap would have closed, decided up to cluster_gap + 1 nodes
  /// sooner. A candidate given by another source meanwhile (addCandidate) that would have joined
  /// one of them opens a cluster of its own instead. Throws std::invalid_argument for an unknown
  /// node.
  void closeJoining(NodeId session_first);
  /// Closes every open cluster and decides all clusters from scratch (end of a run).
  void finish();
  /// Decides the closed clusters again from scratch; open clusters stay open.
  void decideClosedFromScratch();

  /// The verdict changes since the last call, in the order they happened.
  std::vector<DecisionChange> takeChanges();
  /// Waiting candidates that turned out to name a node id that never came (the ids jumped past
  /// it); each message names the candidate. Handed over once.
  std::vector<std::string> takeDroppedCandidates();

  OnlineRrrStatus status() const;
  int numNodes() const { return graph_.numNodes(); }
  int numCandidates() const { return graph_.numCandidates(); }
  bool empty() const { return graph_.numNodes() == 0; }
  const std::vector<NodeId>& nodeIds() const { return graph_.nodeIds(); }
  /// Dense index of a node id; -1 if unknown.
  int indexOf(NodeId id) const;
  /// Poses in the odometry frame (as the nodes arrived).
  const std::vector<core::Pose2>& odomPoses() const { return graph_.initialPoses(); }
  /// Poses in the map frame: the good set's solution, continued by odometry.
  std::vector<core::Pose2> mapPoses() const { return decider_->mapEstimate(); }
  /// map -> odom at the newest node (identity for an empty graph).
  core::Pose2 mapToOdom() const;
  /// True if nodes k - 1 and k are joined by odometry.
  bool odometryBefore(int k) const { return k > 0 && graph_.chain().sameSession(k - 1, k); }
  const LoopCandidate& candidate(int k) const { return graph_.candidate(k); }
  /// The marginal constraints, by dense node index.
  const std::vector<MarginalLink>& marginalLinks() const { return graph_.marginalLinks(); }
  int numDenseFactors() const { return graph_.optimizer().numDenseFactors(); }
  /// The node indices of dense factor `f`, root first.
  const std::vector<int>& denseFactorNodes(int f) const {
    return graph_.optimizer().denseFactorNodes(f);
  }
  Verdict verdict(int candidate) const { return reported_[static_cast<std::size_t>(candidate)]; }
  /// Why the candidate has its verdict (Rrr::reason, or the other verifier's).
  std::string reason(int candidate) const { return decider_->reason(candidate); }
  /// The graph RRR decides on (dense node indices). With another verifier its optimizer is
  /// left as built: each decision runs on a copy of the graph (OnlineVerifier).
  const VerificationGraph& verificationGraph() const { return graph_; }

  /// Nodes at their odometry-frame poses, the odometry, the marginal constraints, then every
  /// candidate in arrival order: the input, which rrr_offline decides again.
  core::PoseGraph toPoseGraph() const;
  /// One row per candidate in arrival order, as in DECISIONS.tsv.
  std::vector<DecisionRow> decisionRows() const;
  /// Odometry + marginal constraints + accepted loops at the map poses.
  core::PoseGraph optimizedPoseGraph() const;
  /// Odometry + marginal constraints + every candidate at the map poses (what a SLAM run
  /// produced, for rrr_offline).
  core::PoseGraph mapPoseGraph() const;

 private:
  struct Odometry {
    int from;
    int to;
    core::Pose2 measurement;
    Eigen::Matrix3d information;
  };
  struct Waiting {
    NodeId from;
    NodeId to;
    core::Pose2 measurement;
    Eigen::Matrix3d information;
  };

  int appendNode(NodeId id, const core::Pose2& odom_pose);
  /// Nodes at `poses`, the odometry, then the candidates (all, or the accepted ones).
  core::PoseGraph poseGraph(const std::vector<core::Pose2>& poses, bool accepted_only) const;
  void insertCandidate(int from, int to, const core::Pose2& measurement,
                       const Eigen::Matrix3d& information);
  void admitWaitingCandidates();
  void collectChanges();

  OnlineRrrParams params_;
  VerificationGraph graph_;
  std::unique_ptr<OnlineDecider> decider_;
  std::vector<Odometry> odometry_;
  std::map<std::pair<NodeId, NodeId>, std::vector<int>> candidates_by_ends_;
  std::deque<Waiting> waiting_;
  std::vector<Verdict> reported_;
  std::vector<DecisionChange> changes_;
  std::vector<std::string> dropped_;
};

}  // namespace rrr_graphslam::rrr
