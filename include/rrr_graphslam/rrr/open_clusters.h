#pragma once
// The time clusters of loop candidates that arrive while the robot moves (iRRR, Latif et al.,
// IROS 2012): a candidate joins, and merges, every open cluster holding a member whose both ends
// lie within `gap` nodes of its own, in the same session (clustering.h's rule); a cluster closes
// once the robot is more than `gap` nodes past its newest end, when no later candidate can join
// it, so the closed clusters equal the batch clustering of the same candidates. Shared by every
// online decision (IncrementalRrr, OnlineVerifier): it only groups, it decides nothing.

#include <functional>
#include <vector>

#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

class OpenClusters {
 public:
  /// `graph` must outlive this object; gap > 0 nodes.
  OpenClusters(const VerificationGraph& graph, int gap) : graph_(graph), gap_(gap) {}

  /// Candidate `candidate` of the graph joins the open clusters (it does not move the robot:
  /// call advanceTo(its newest end) first). Returns true if the cluster it is in now is already
  /// behind the robot (a late candidate), so that advanceTo(currentNode()) closes it.
  bool add(int candidate);
  /// The robot reached `node` (never moves back). Returns the clusters it left behind, closed,
  /// each as its sorted candidate indices, in the order they were opened.
  std::vector<std::vector<int>> advanceTo(int node);
  /// Closes every open cluster (the end of a run), in the order they were opened.
  std::vector<std::vector<int>> closeAll();
  /// Closes now, in the order they were opened, the open clusters that join the session starting
  /// at node `session_first` to the nodes before it (a member with one end on each side). For a
  /// caller that will propose no candidate joining them for more than the gap (the front end's
  /// relocalization search resting after a few matches): no later candidate could join these
  /// clusters, so closing them early leaves the clusters the batch ones, only decided sooner (a
  /// candidate that would have joined one after all opens a cluster of its own).
  std::vector<std::vector<int>> closeJoining(int session_first);

  int size() const { return static_cast<int>(open_.size()); }
  int currentNode() const { return current_node_; }
  int gap() const { return gap_; }

 private:
  struct Cluster {
    std::vector<int> members;
    int newest = -1;  // largest node index among the members' ends
  };
  /// Closes the open clusters `closes` picks, in the order they were opened.
  std::vector<std::vector<int>> closeIf(const std::function<bool(const Cluster&)>& closes);

  const VerificationGraph& graph_;
  int gap_;
  int current_node_ = 0;
  std::vector<Cluster> open_;
};

}  // namespace rrr_graphslam::rrr
