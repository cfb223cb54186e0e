#pragma once
// Node marginalization in an SE(2) pose graph (Carlevaris-Bianco, Kaess, Eustice, "Generic Node
// Removal for Factor-Graph SLAM", T-RO 2014, Sec. III): the nodes M a trimmed submap owns leave
// the graph, and the information their constraints held about the rest is kept as one dense
// factor over their Markov blanket.
//
// Steps, with the paper's names:
//   1. Markov blanket: B = the nodes outside M that share a constraint with a node of M. Only
//      the constraints touching M are used; all others stay in the graph untouched.
//   2. Linearize those constraints at the current estimate (linearized_constraints.h): the
//      quadratic model over M and B, information Lambda and gradient g.
//   3. Schur complement over M:
//        Lambda_B = Lambda_BB - Lambda_BM Lambda_MM^-1 Lambda_MB
//        g_B      = g_B - Lambda_BM Lambda_MM^-1 g_M
//        c        = chi2 - g_M^T Lambda_MM^-1 g_M
//      so that c + 2 g_B^T dx_B + dx_B^T Lambda_B dx_B is the removed constraints' chi2,
//      minimized over M, to second order in the blanket's perturbation dx_B.
//
// Gauge: the constraints are relative, so a global rigid motion of M and B leaves them unchanged.
// Lambda_B has a 3-dim null space per connected piece of the blanket (blanket nodes linked
// through removed nodes): rank 3(|B| - pieces). No prior is added; callers that need a full-rank
// distribution anchor a node (chow_liu.h, gaussian_kl.h do). Blocks between blanket nodes of
// different pieces come out exactly zero, not just small (Lambda_MM is block diagonal over the
// pieces, and neither its factor nor the solves ever combine two pieces' entries), which is how
// chow_liu.h finds the pieces. The optimizer's fixed node is a gauge choice, not information:
// removing it leaves the graph to be anchored elsewhere by the caller.
//
// Lambda_MM is positive definite exactly when every connected piece of M (through the
// constraints touching M) has a constraint to a blanket node (constraint informations are
// checked positive definite). A piece without one (a removed component of its own) throws.

#include <cstddef>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/pose_graph.h"

namespace rrr_graphslam::core {

/// What marginalizing M leaves: the dense factor over the Markov blanket, and what it replaces.
struct Marginal {
  std::vector<NodeId> removed_nodes;             ///< M, increasing ids
  std::vector<std::size_t> removed_constraints;  ///< input constraints touching M, increasing
  std::vector<std::size_t> removed_factors;      ///< input dense factors touching M, increasing
  std::vector<NodeId> blanket;                   ///< Markov blanket B, increasing ids
  std::vector<Pose2> linearization_point;        ///< blanket poses, in blanket order
  Eigen::MatrixXd information;                   ///< Lambda_B, 3|B| x 3|B|, blanket order
  Eigen::VectorXd gradient;                      ///< g_B, 3|B|
  double chi2_at_linearization = 0.0;            ///< c: removed chi2 minimized over M, at x0
};

/// Marginalizes `removed` out of the graph given by `constraints` and `poses` (the current
/// estimate; it must hold every node of a constraint touching M). Sparse path: Lambda over
/// M and B only, Lambda_MM factored by CHOLMOD (SparseSolver), never a full-graph inverse.
/// Throws std::invalid_argument naming the problem: M empty or listing a node twice, a node
/// without a pose, a non-finite pose or measurement, an information matrix that is not
/// symmetric positive definite, a self-loop, or a piece of M with no constraint to B.
Marginal marginalizeNodes(const std::vector<PoseConstraint>& constraints,
                          const std::map<NodeId, Pose2>& poses, const std::vector<NodeId>& removed);

/// The same where dense factors (dense_factor.h, an earlier marginal kept exactly) are part of the
/// graph: those holding a node of M are marginalized with the constraints touching M, and their
/// other nodes join the blanket. Also throws for a factor with denseFactorProblem() or a node
/// without a pose.
Marginal marginalizeNodes(const std::vector<PoseConstraint>& constraints,
                          const std::vector<DenseFactor>& factors,
                          const std::map<NodeId, Pose2>& poses, const std::vector<NodeId>& removed);

/// The same on a PoseGraph (constraint k is edge k, its dense factors, poses the graph's).
Marginal marginalizeNodes(const PoseGraph& graph, const std::vector<NodeId>& removed);

/// The slow, obvious version: the same Schur complement with dense Eigen matrices over M and B.
/// Tests check the sparse path against it.
Marginal marginalizeNodesDense(const std::vector<PoseConstraint>& constraints,
                               const std::map<NodeId, Pose2>& poses,
                               const std::vector<NodeId>& removed);
Marginal marginalizeNodesDense(const std::vector<PoseConstraint>& constraints,
                               const std::vector<DenseFactor>& factors,
                               const std::map<NodeId, Pose2>& poses,
                               const std::vector<NodeId>& removed);

/// The marginal as dense factors (dense_factor.h), one per connected piece of its blanket with
/// at least two nodes (a node alone in its piece holds nothing: its rows are the gauge). Throws
/// std::invalid_argument when a piece's information is singular beyond its gauge.
std::vector<DenseFactor> denseFactors(const Marginal& marginal);

/// Connected pieces of the blanket: nodes coupled by a nonzero block of the marginal (exactly
/// zero between pieces, see above), each piece's members as indices into `blanket` in its order;
/// the first is the piece's root.
std::vector<std::vector<std::size_t>> blanketPieces(const Marginal& marginal);

/// The dense factor's chi2 at `blanket_poses` (in blanket order):
/// c + 2 g^T dx + dx^T Lambda dx with dx = perturbation(blanket_poses, linearization_point).
/// What the removed constraints contribute to the graph's chi2 when the dense replacement keeps
/// them, exact to second order near the linearization point.
double marginalChi2(const Marginal& marginal, const std::vector<Pose2>& blanket_poses);

}  // namespace rrr_graphslam::core
