#pragma once
// Incremental RRR (Latif, Cadena, Neira, "Realizing, reversing, recovering: incremental robust
// loop closing over time using the iRRR algorithm", IROS 2012): loop candidates arrive while the
// robot moves, in node order. A cluster is closed once the robot is more than `gap` nodes past
// its newest link (no later candidate can then join it, so clusters equal the batch ones); it is
// tested on its own at once and then against the good set's map (Rrr::decideIncrementally):
// accepted when it fits the map, rejected when even the linearized joint test fails, otherwise
// tested jointly with optimization, which can reverse earlier accepted clusters (a lone link
// that the map cannot test yet waits instead: RrrParams::online_untestable_ratio). finish()
// closes the rest and decides every cluster again from the initial estimate (realize, reverse,
// recover): the batch decision, whatever order the candidates came in.

#include <string>
#include <vector>

#include "rrr_graphslam/rrr/open_clusters.h"
#include "rrr_graphslam/rrr/replay_plan.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {

class IncrementalRrr {
 public:
  IncrementalRrr(VerificationGraph& graph, const RrrParams& params, int cluster_gap);

  /// A candidate arrives; normally its newest end is the robot's current node. A late one (a
  /// front end that searched in the background) joins the open clusters within the gap; one more
  /// than the gap behind the robot forms a cluster of its own, closed and decided at once (or,
  /// a lone link the map cannot test yet, left waiting: RrrParams::online_untestable_ratio).
  /// Returns true if a cluster was closed (and, unless deferred, a decision made).
  bool addCandidate(int candidate);
  /// The robot reached `node`: closes and decides the clusters it has left behind (from scratch,
  /// in a graph of several sessions, when it passed a multiple of
  /// RrrParams::incremental_rebatch_every since the last time).
  bool advanceTo(int node);
  /// Closes and decides the open clusters joining the session that starts at `session_first` to
  /// the earlier ones, for a caller that proposes no candidate joining them for more than the gap
  /// (OpenClusters::closeJoining); returns as advanceTo.
  bool closeJoining(int session_first);
  /// After the last candidate: closes every open cluster and decides all of them from scratch.
  /// Clusters waiting for their session to be placed still wait (Rrr::rejectUnplaced ends that).
  void finish();
  /// The end of a replay that goes on: the closed clusters decided from scratch, the open ones
  /// left open (their candidates pending until more nodes close them).
  void finishReplayKeepingOpen();
  /// While deferred, a closed cluster gets its intra test only and no decision is made: a saved
  /// graph replayed to be decided once, by finish() (whose decision from scratch does not depend
  /// on the decisions before it, so making them would be wasted).
  void deferDecisions(bool defer) { defer_ = defer; }
  /// Decides the closed clusters again from scratch (the batch decision over them); open
  /// clusters stay open.
  void decideClosedFromScratch() { rrr_.decideFromScratch(); }

  const Rrr& rrr() const { return rrr_; }
  Rrr& rrr() { return rrr_; }
  int numOpenClusters() const { return open_.size(); }
  int currentNode() const { return open_.currentNode(); }
  int clusterGap() const { return open_.gap(); }

 private:
  /// The next decision from scratch: at the next multiple of incremental_rebatch_every past the
  /// current node.
  void scheduleNextRebatch();
  /// Adds the closed clusters to RRR and decides (unless deferred); false if none.
  bool decideClosed(const std::vector<std::vector<int>>& closed);

  VerificationGraph& graph_;
  Rrr rrr_;
  OpenClusters open_;
  int next_rebatch_;  // node at which the next decision is made from scratch
  bool defer_ = false;
};

/// What a robot saw during a replay: a candidate's arrival (previous == verdict == kPending) or a
/// change of its verdict, when the graph held `nodes` nodes, `seconds` after the replay started.
/// `final`: the end of the run (finish()'s decision and the unplaced sessions' rejection).
struct ReplayEvent {
  int candidate;  ///< the graph's candidate index
  int nodes;
  double seconds;
  bool final;
  int cluster;  ///< -1 while the candidate's cluster is open
  Verdict previous;
  Verdict verdict;
  std::string reason;
};

/// Replays `graph` as a robot builds it (replay_plan.h: nodes in order with their odometry, each
/// candidate right after its newest end), and IncrementalRrr works on a graph holding only what
/// has arrived, so each decision costs what it would on the robot at that point. As OnlineRrr
/// does, every node's arrival closes (and decides) the clusters the robot has left behind, with or
/// without a candidate. `latencies_sec` gets the time of every update that can block the robot:
/// each candidate's arrival and each node's that closed clusters. If `events` is given, every
/// arrival and verdict change as it happened; verdicts, cluster_of and the graph's optimizer
/// afterwards as in runBatchRrr.
RrrSummary runIncrementalRrr(VerificationGraph& graph, const RrrParams& params,
                             std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                             const ProgressFunction& progress = {},
                             std::vector<double>* latencies_sec = nullptr,
                             std::vector<std::string>* reasons = nullptr,
                             std::vector<ReplayEvent>* events = nullptr);

}  // namespace rrr_graphslam::rrr
