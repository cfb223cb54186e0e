#pragma once
// What RRR works on: one optimizer holding the whole pose graph, in which odometry is always
// active and every loop candidate can be switched on and off, plus the odometry chain for the
// intra-cluster tests. Node k is the k-th smallest node id of the PoseGraph; candidate k is the
// k-th loop-candidate edge in edge order.
//
// Marginal constraints (core::EdgeKind::kMarginal, left where lifelong trimming removed nodes)
// are trusted like odometry and always active, but join any two nodes and are no part of the
// odometry chain: a session whose middle was trimmed is two chains, held together by them.
// Dense factors (core/dense_factor.h, the exact marginal a `dense` trim leaves) are trusted the
// same way, each over several nodes. trustedComponents() says which nodes odometry, marginal
// constraints and dense factors hold together.

#include <cstddef>
#include <vector>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/rrr/odometry_chain.h"

namespace rrr_graphslam::rrr {

/// A marginal constraint, always active.
struct MarginalLink {
  int from;        ///< dense node index
  int to;          ///< dense node index
  int constraint;  ///< index in the optimizer
};

struct LoopCandidate {
  std::size_t edge;  ///< index in the PoseGraph's edges
  int from;          ///< dense node index
  int to;            ///< dense node index
  int constraint;    ///< index in the optimizer
  core::Pose2 measurement;
  Eigen::Matrix3d information;
};

class VerificationGraph {
 public:
  /// Uses the graph's edge kinds: odometry edges must join consecutive node ids (in id order);
  /// throws std::invalid_argument naming the edge otherwise. Candidates start switched off;
  /// marginal constraints are always on.
  VerificationGraph(const core::PoseGraph& graph, const core::OptimizerParams& params);

  /// An empty graph that grows online (a robot, a replay): nodes in order, each with its
  /// odometry, and loop candidates between nodes that exist.
  explicit VerificationGraph(const core::OptimizerParams& params) : optimizer_(params) {}
  /// Appends a node and returns its index; it starts a new session until addOdometry links it.
  int addNode(core::PoseGraph::NodeId id, const core::Pose2& initial_pose);
  /// Trusted odometry between the newest node and the one before, in either direction; throws
  /// std::invalid_argument for any other pair.
  void addOdometry(int from, int to, const core::Pose2& measurement,
                   const Eigen::Matrix3d& information);
  /// A marginal constraint between two distinct existing nodes, always active. Returns its
  /// index in marginalLinks().
  int addMarginal(int from, int to, const core::Pose2& measurement,
                  const Eigen::Matrix3d& information);
  /// A dense factor over existing distinct nodes (`nodes`, in the factor's order; the factor's own
  /// ids are kept for poseGraphWith), always active. Returns its index in the optimizer.
  int addDenseFactor(const std::vector<int>& nodes, const core::DenseFactor& factor);
  /// A loop candidate between existing nodes, switched off; `edge` is the caller's id for it.
  /// Returns the candidate index.
  int addCandidate(int from, int to, const core::Pose2& measurement,
                   const Eigen::Matrix3d& information, std::size_t edge);

  int numNodes() const { return static_cast<int>(node_ids_.size()); }
  int numCandidates() const { return static_cast<int>(candidates_.size()); }
  const LoopCandidate& candidate(int k) const { return candidates_[static_cast<std::size_t>(k)]; }
  const std::vector<MarginalLink>& marginalLinks() const { return marginal_; }
  const std::vector<core::PoseGraph::NodeId>& nodeIds() const { return node_ids_; }
  /// Per node, the component that odometry, marginal constraints and dense factors (the trusted
  /// ones) hold it in: 0, 1, ... in order of their first nodes. Without marginal constraints these
  /// are the odometry chain's sessions.
  std::vector<int> trustedComponents() const;
  /// How many parts trustedComponents() finds (the sessions, less those marginals joined).
  int numTrustedComponents() const { return numComponents(trustedComponents()); }
  /// The number of components in a trustedComponents() labelling.
  static int numComponents(const std::vector<int>& component);
  /// Per node, the part of the map it lies in: the trusted components that `candidates` (the
  /// accepted ones, say) join together, as one id; two nodes share it when a path of trusted
  /// constraints and those candidates joins them.
  std::vector<std::size_t> componentsJoinedBy(const std::vector<int>& candidates) const;
  /// chi2 of the trusted constraints alone (odometry and marginal constraints, no candidate) at
  /// their own minimum: zero for odometry (a forest), positive once marginal constraints close
  /// cycles with it (they carry loops that bent the chain). RRR's joint tests measure what the
  /// candidates add to it. Optimized in a copy of the trusted graph (this optimizer keeps its
  /// state) once per change of the marginal constraints.
  double trustedChi2() const;
  /// chi2 of the trusted constraints at `poses` (one per node).
  double trustedChi2At(const std::vector<core::Pose2>& poses) const;
  const std::vector<core::Pose2>& initialPoses() const { return initial_poses_; }

  core::Optimizer& optimizer() { return optimizer_; }
  const core::Optimizer& optimizer() const { return optimizer_; }
  const OdometryChain& chain() const { return chain_; }

  /// The graph as a batch verifier reads it: the nodes at their initial poses, the odometry and
  /// marginal constraints, then `candidates` (ascending) as loop candidates, so that candidate i
  /// of a VerificationGraph made from it is candidates[i] here.
  core::PoseGraph poseGraphWith(const std::vector<int>& candidates) const;
  /// Appends to `poses` (map poses of the first nodes) the nodes it lacks, following odometry
  /// from the node before, or at its initial pose where a session starts.
  void extendByOdometry(std::vector<core::Pose2>& poses) const;

  /// The nodes the given candidates touch, sorted, each once.
  std::vector<int> touchedNodes(const std::vector<int>& candidates) const;

  /// Switches on exactly the given candidates (all others off).
  void activateOnly(const std::vector<int>& candidates);
  /// One optimization of the odometry with exactly `candidates` switched on, as `request` says
  /// (from where, how, how long); the optimizer keeps that active set and the poses reached.
  core::OptimizationResult optimize(const std::vector<int>& candidates,
                                    const core::OptimizationRequest& request = {});

 private:
  /// The optimizer's constraints that are no candidate (odometry and marginal), in order.
  std::vector<int> trustedConstraints() const;
  std::vector<core::PoseGraph::NodeId> node_ids_;
  std::vector<core::Pose2> initial_poses_;
  std::vector<LoopCandidate> candidates_;
  std::vector<MarginalLink> marginal_;
  core::Optimizer optimizer_;
  mutable double trusted_chi2_ = 0.0;
  // marginal_.size() + dense factors it was computed for
  mutable std::size_t trusted_chi2_marginals_ = 0;
  std::size_t numMarginalTerms() const {
    return marginal_.size() + static_cast<std::size_t>(optimizer_.numDenseFactors());
  }
  OdometryChain chain_;
};

}  // namespace rrr_graphslam::rrr
