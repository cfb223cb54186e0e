#pragma once
// Chow-Liu tree sparsification of a marginal (Kretzschmar & Stachniss, IJRR 2012;
// Carlevaris-Bianco, Kaess, Eustice, T-RO 2014, Sec. IV): the dense factor marginalization
// leaves over the Markov blanket is replaced by |B| - 1 ordinary SE(2) relative-pose constraints,
// the maximum mutual-information spanning tree of the marginal, so the graph stays sparse.
//
// Steps, with the papers' names:
//   1. Gauge: the marginal is relative (a rigid motion of the blanket leaves it unchanged), so
//      each connected piece of the blanket is anchored at its first node (its pose held at the
//      linearization point) and the rest of the piece's information is inverted. This is
//      the linearized root-shift: the relative poses of the other nodes to the root are a
//      per-node invertible function of their poses once the root is held, so they carry the
//      same distribution. A relative pose between two blanket nodes does not depend on the
//      gauge, so neither does anything below (nor does the choice of root).
//   2. Mutual information: with the gauge left flat, every single pose has the same (unbounded)
//      entropy, and a pair's joint entropy exceeds it by the entropy of their relative pose, so
//      the pairwise mutual information is, up to a constant common to all pairs,
//      -H(relative pose i -> j) = -1/2 ln det(2 pi e Sigma_ij), Sigma_ij the covariance of
//      the relative pose (the optimizer's edge error, propagated from the pair's joint marginal
//      with its Jacobians). That is the weight used and reported.
//   3. Maximum spanning tree (Kruskal, UnionFind) over those weights.
//   4. Each tree edge becomes a constraint with information Sigma_ij^-1 (in the error's
//      coordinates at its measurement). Measurement: see ChowLiuParams::match_gradient.
//   5. Conservative scaling (ChowLiuParams::conservative): the tree takes its edges' relative
//      poses as independent, which overstates the marginal's information along directions where
//      they are correlated (by the largest generalized eigenvalue of the two informations, at
//      least 1). Every edge's information is scaled down, per piece, so the tree's information
//      is at most the marginal's (the consistency asked of a sparse approximation by Vial,
//      Durrant-Whyte, Bailey, IROS 2011, and Carlevaris-Bianco, Eustice, ICRA 2014): by that
//      eigenvalue for all, or (ChowLiuParams::per_edge_scaling) each edge by its own scale.
// Why this weight: a spanning tree of relative-pose constraints makes its edges' relative poses
// independent, so KL(marginal || tree) = sum over edges H(relative pose) - H(marginal) (the
// marginal's entropy is the same in every tree's coordinates: the relative-pose Jacobians have
// determinant +-1). The maximum spanning tree on -H minimizes it: the Chow-Liu theorem for
// relative-pose edges (test_chow_liu checks it against every spanning tree of small blankets).
//
// Rank rule: blanket nodes of different pieces (blocks of the marginal exactly zero between
// them, see marginalization.h) share no information: no edge joins them, and the result is a
// spanning forest, one tree per piece. Within a piece the anchored information must be positive
// definite (it is for any marginal of constraints with positive-definite information); a
// marginal singular beyond its gauge throws std::invalid_argument naming the piece.
//
// The linear term: the marginal's gradient g at the linearization point is not zero in general
// (the removed constraints pull the blanket against the rest of the graph, even at the graph's
// minimum). Measurements between(x_i, x_j) (GLC's and Kretzschmar's choice) have zero error
// there and drop g: the re-optimized graph moves. On test_chow_liu's optimized loop that made up
// 86-91% of KL(exact || tree), and KL(tree) / KL(delete) 0.30-0.35 instead of 0.03-0.05.
// Measurements chosen so that the tree's gradient is g (match_gradient) keep it: the tree then
// differs from the marginal in its information only.
//
// Why conservative: in the whole graph (gaussian_kl.h) KL(exact || replacement) is
// 1/2 [tr S - k - ln det S] + a gradient term, S = I + F^T (Lambda_repl - Lambda_marg) F. The
// plain tree's overstated directions give eigenvalues of S above 1, and where the rest of the
// graph already holds the blanket tightly they cost more than deleting the constraints costs
// (on three laps of a room the plain tree lost more than deletion in several trims). With
// 0 <= Lambda_tree <= Lambda_marg, S lies between deletion's S and I, where tr S - ln det S
// only falls as S grows, and the tree has no gradient term: KL(tree) <= KL(delete) at the
// graph's minimum (where trims linearize: p0's mean), whatever the rest of the graph holds.

#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/marginalization.h"

namespace rrr_graphslam::core {

struct ChowLiuParams {
  /// true (default): measurements chosen so that the tree's gradient at the linearization point
  /// is the marginal's (the tree's linear term exact, its information the Chow-Liu one);
  /// false: measurement between(x_i, x_j) at the linearization point, zero error there.
  /// A weak tree edge must be stretched far to pull as hard as the marginal does: where the
  /// measurements would turn by more than 90 degrees from the relative poses (on
  /// Intel's third session the plain tree's up to 3 rad, the conservative one's beyond pi, where
  /// the angle wraps and the gradient is lost), all the offsets are shrunk together to that
  /// bound and the tree keeps that fraction of the marginal's gradient (its KL still at most
  /// deletion's, which keeps none).
  bool match_gradient = true;
  /// true (default): the edges' information is scaled down until the tree states no more than
  /// the marginal in any direction (per_edge_scaling below; with one scale for all, the largest
  /// generalized eigenvalue of the two over the piece, at least 1), so the tree never claims
  /// more than the marginal knows: replacing
  /// the marginal by it can only lose information, never invent it, and over the whole graph it
  /// then loses at most what deleting loses (see the header's comment). false: the Chow-Liu
  /// edges' own information, the relative poses' marginal covariances inverted.
  bool conservative = true;
  /// With `conservative`: true (default), each edge its own scale where that loses less (the
  /// Schur test's per-edge bound, or the best mix of it and the uniform one: an edge the others
  /// hardly correlate with keeps nearly all its information; chow_liu.cpp); false, one scale
  /// for all the piece's edges, 1 / the largest overstatement. Either way the tree states no
  /// more than the marginal in any direction.
  bool per_edge_scaling = true;
};

struct ChowLiuEdge {
  PoseConstraint constraint;  ///< from < to (blanket ids)
  /// The Chow-Liu weight: -1/2 ln det(2 pi e Sigma_ij), nats; only differences are meaningful.
  double mutual_information_nats = 0.0;
};

/// The Chow-Liu tree (a forest if the blanket has several pieces) of `marginal`, edges in the
/// order Kruskal takes them (decreasing mutual information). Throws std::invalid_argument for
/// mismatched sizes, non-finite or asymmetric information, or a piece singular beyond its gauge.
std::vector<ChowLiuEdge> chowLiuTree(const Marginal& marginal, const ChowLiuParams& params = {});

/// What replaces the removed constraints in the graph.
enum class MarginalReplacement {
  kChowLiuTree,  ///< chowLiuTree()'s constraints
  kDense,        ///< the marginal itself, one factor over the whole blanket
  kDelete,       ///< nothing: the removed constraints' information is dropped
};

/// The quadratic model, over the blanket (its order, at its linearization point), of what
/// `replacement` puts into the graph: the tree's constraints linearized, the marginal itself,
/// or zero. gaussian_kl.h's replacementKl compares it with the marginal.
QuadraticModel replacementModel(const Marginal& marginal, MarginalReplacement replacement,
                                const ChowLiuParams& params = {});

}  // namespace rrr_graphslam::core
