#pragma once
// How OnlineRrr decides its loop candidates while they arrive: the seam between the graph a robot
// builds and the verifier that judges it. Either RRR itself, incrementally (iRRR:
// IncrementalRrr, the default), or one of the batch verifiers of verifier.h (PCM, SCGP, GNC),
// decided again each time a time cluster closes (OnlineVerifier), to compare them on a robot or
// a replay. Both group the candidates into the same time clusters (open_clusters.h): a candidate
// stays pending while its cluster is open.

#include <memory>
#include <string>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/verification_graph.h"
#include "rrr_graphslam/rrr/verifier_choice.h"

namespace rrr_graphslam::rrr {

class OnlineDecider {
 public:
  virtual ~OnlineDecider() = default;

  /// Candidate `candidate` of the graph arrived (its ends exist). Returns true if a cluster was
  /// closed (and, unless deferred, a decision made).
  virtual bool addCandidate(int candidate) = 0;
  /// The robot reached node `node`; returns as addCandidate.
  virtual bool advanceTo(int node) = 0;
  /// The open clusters joining the session that starts at node `session_first` to the earlier
  /// ones closed and decided now, for a caller that proposes no candidate joining them for more
  /// than the cluster gap (OpenClusters::closeJoining); returns as addCandidate.
  virtual bool closeJoining(int session_first) = 0;
  /// After the last candidate: every open cluster closed and all of them decided from scratch.
  virtual void finish() = 0;
  /// The run ends: what still waits to be decided is rejected (RRR: clusters of a session never
  /// placed on the map); nothing for verifiers that make nobody wait.
  virtual void endRun() = 0;
  /// The end of a replay that goes on: the closed clusters decided from scratch, the open ones
  /// left open.
  virtual void finishReplayKeepingOpen() = 0;
  /// While deferred, a closed cluster is not decided (a replay decided once at its end).
  virtual void deferDecisions(bool defer) = 0;
  /// The closed clusters decided again from scratch; open ones stay open.
  virtual void decideClosedFromScratch() = 0;
  /// A map that earlier decisions made (a loaded map's saved poses, one per node of the graph
  /// now), for the next decision from scratch to start from (RRR: Rrr::seedPreviousMap).
  /// Verifiers that keep no map ignore it.
  virtual void seedPreviousMap(std::vector<core::Pose2> map) { (void)map; }

  virtual Verdict verdict(int candidate) const = 0;
  /// The candidate's cluster; -1 while it is open.
  virtual int clusterOf(int candidate) const = 0;
  /// Why the candidate has its verdict: the step that decided and its statistic.
  virtual std::string reason(int candidate) const = 0;
  /// Map-frame poses of every node of the graph: the accepted candidates' solution, continued
  /// by odometry to the nodes that arrived after it.
  virtual std::vector<core::Pose2> mapEstimate() const = 0;
  virtual int numClusters() const = 0;  ///< closed
  virtual int numOpenClusters() const = 0;
  virtual int optimizations() const = 0;
};

/// The decider `choice` names for `graph` (which must outlive it): RRR with `params`, the others
/// with its alpha (and cluster_gap for SCGP, as rrr_offline); time clusters of `cluster_gap`
/// nodes (> 0).
std::unique_ptr<OnlineDecider> makeOnlineDecider(VerificationGraph& graph,
                                                 const VerifierChoice& choice,
                                                 const RrrParams& params, int cluster_gap);

}  // namespace rrr_graphslam::rrr
