#pragma once
// An SE(2) pose graph stored in MRPT's CNetworkOfPoses2DInf, plus what MRPT does not keep:
// the order edges were added in (file order), and each edge's kind (trusted odometry, an
// unverified loop candidate, or a trusted marginal constraint left by node removal). Duplicate
// edges between the same pair are separate edges.
//
// Beside the edges, dense factors (dense_factor.h): the exact marginal of removed nodes over
// their Markov blanket, trusted like marginal edges, kept in their own list (MRPT's network holds
// pairwise edges only).
//
// Node ids are MRPT's TNodeID and need not be contiguous. Edge indices are positions in
// edges(), i.e. insertion order; RRR and the tools key everything on them.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <Eigen/Core>

#include "rrr_graphslam/core/dense_factor.h"
#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

enum class EdgeKind : std::uint8_t {
  kOdometry,       ///< sequential constraint, trusted
  kLoopCandidate,  ///< loop closure to be verified (RRR decides)
  /// Trusted relative-pose constraint between any two nodes that replaced the constraints of
  /// marginalized nodes (lifelong trimming, chow_liu.h): always active, never decided, and not
  /// part of an odometry chain.
  kMarginal,
};

class PoseGraph {
 public:
  using Network = mrpt::graphs::CNetworkOfPoses2DInf;
  using NodeId = mrpt::graphs::TNodeID;

  struct Edge {
    NodeId from;
    NodeId to;
    EdgeKind kind;
    Network::edges_map_t::iterator storage;  ///< the MRPT edge with measurement and information
  };

  PoseGraph() = default;
  PoseGraph(const PoseGraph& other);
  PoseGraph& operator=(const PoseGraph& other);
  PoseGraph(PoseGraph&&) noexcept = default;
  PoseGraph& operator=(PoseGraph&&) noexcept = default;

  /// The default marking of the RRR paper: |from - to| == 1 is odometry, anything else a candidate.
  static EdgeKind defaultKind(NodeId from, NodeId to);

  bool hasNode(NodeId id) const { return network_.nodes.count(id) != 0; }
  /// Throws std::invalid_argument if the id exists.
  void addNode(NodeId id, const Pose2& pose);
  Pose2 pose(NodeId id) const;
  void setPose(NodeId id, const Pose2& pose);

  /// Throws std::invalid_argument for an unknown end or a self-loop. Returns the edge index.
  std::size_t addEdge(NodeId from, NodeId to, const Pose2& measurement,
                      const Eigen::Matrix3d& information, EdgeKind kind);

  std::size_t numNodes() const { return network_.nodes.size(); }
  std::size_t numEdges() const { return edges_.size(); }
  const std::vector<Edge>& edges() const { return edges_; }
  const Edge& edge(std::size_t index) const { return edges_.at(index); }
  void setEdgeKind(std::size_t index, EdgeKind kind) { edges_.at(index).kind = kind; }
  Pose2 measurement(std::size_t index) const;
  Eigen::Matrix3d information(std::size_t index) const;

  /// Throws std::invalid_argument for an unknown node or a factor with denseFactorProblem().
  /// Returns the factor's index.
  std::size_t addDenseFactor(DenseFactor factor);
  const std::vector<DenseFactor>& denseFactors() const { return dense_factors_; }

  /// Node ids in increasing order.
  std::vector<NodeId> nodeIds() const;

  /// Connected components over all edges and dense factors, each sorted, ordered by their smallest
  /// id.
  std::vector<std::vector<NodeId>> connectedComponents() const;

  const Network& network() const { return network_; }

 private:
  void copyFrom(const PoseGraph& other);

  Network network_;
  std::vector<Edge> edges_;
  std::vector<DenseFactor> dense_factors_;
};

}  // namespace rrr_graphslam::core
