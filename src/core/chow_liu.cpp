#include "rrr_graphslam/core/chow_liu.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "rrr_graphslam/core/largest_eigenvalue.h"
#include "rrr_graphslam/core/spd_inverse.h"
#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::core {
namespace {

void checkMarginal(const Marginal& marginal) {
  const auto n = static_cast<Eigen::Index>(3 * marginal.blanket.size());
  if (marginal.linearization_point.size() != marginal.blanket.size() ||
      marginal.information.rows() != n || marginal.information.cols() != n ||
      marginal.gradient.size() != n) {
    throw std::invalid_argument("chowLiuTree: the marginal's sizes disagree (" +
                                std::to_string(marginal.blanket.size()) + " blanket nodes, " +
                                std::to_string(marginal.linearization_point.size()) + " poses, " +
                                std::to_string(marginal.information.rows()) + "x" +
                                std::to_string(marginal.information.cols()) + " information, " +
                                std::to_string(marginal.gradient.size()) + " gradient)");
  }
  if (!marginal.information.allFinite()) {
    throw std::invalid_argument("chowLiuTree: the marginal's information is not finite");
  }
  const double scale = marginal.information.cwiseAbs().maxCoeff();
  if ((marginal.information - marginal.information.transpose()).cwiseAbs().maxCoeff() >
      1e-9 * scale) {
    throw std::invalid_argument("chowLiuTree: the marginal's information is not symmetric");
  }
}

// Gauge: each piece anchored at its root, the others' joint covariance the inverse of their
// information (the roots keep zero rows and columns).
Eigen::MatrixXd anchoredCovariance(const Marginal& marginal,
                                   const std::vector<std::vector<std::size_t>>& pieces) {
  const auto size = static_cast<Eigen::Index>(3 * marginal.blanket.size());
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(size, size);
  for (const auto& piece : pieces) {
    if (piece.size() < 2) continue;
    std::vector<Eigen::Index> rows;
    for (std::size_t k = 1; k < piece.size(); ++k) {
      for (int r = 0; r < 3; ++r) rows.push_back(3 * static_cast<Eigen::Index>(piece[k]) + r);
    }
    const std::optional<Eigen::MatrixXd> inverse = spdInverse(marginal.information(rows, rows));
    if (!inverse) {
      std::string ids;
      for (std::size_t k : piece) {
        ids += (ids.empty() ? "" : ", ") + std::to_string(marginal.blanket[k]);
      }
      throw std::invalid_argument("chowLiuTree: the marginal over blanket nodes {" + ids +
                                  "} is singular beyond its gauge (rank below 3(n-1) with node " +
                                  std::to_string(marginal.blanket[piece.front()]) +
                                  " anchored): some relative pose carries no information");
    }
    covariance(rows, rows) = *inverse;
  }
  return covariance;
}

// A blanket pair's relative pose as the optimizer's edge error sees it at the linearization
// point (measurement between(x_i, x_j)): its Jacobians, its covariance propagated from the pair's
// joint covariance, and the Chow-Liu weight.
struct Candidate {
  std::size_t i;
  std::size_t j;
  double mutual_information_nats;
  Eigen::Matrix3d information;
  EdgeLinearization linearization;
};

Candidate relativePose(const Marginal& marginal, const Eigen::MatrixXd& covariance, std::size_t i,
                       std::size_t j) {
  const Pose2& x_i = marginal.linearization_point[i];
  const Pose2& x_j = marginal.linearization_point[j];
  const EdgeLinearization lin = linearizeEdge(x_i, x_j, between(x_i, x_j));
  const auto a = static_cast<Eigen::Index>(3 * i), b = static_cast<Eigen::Index>(3 * j);
  const Eigen::Matrix3d sigma = lin.J_from * covariance.block<3, 3>(a, a) * lin.J_from.transpose() +
                                lin.J_from * covariance.block<3, 3>(a, b) * lin.J_to.transpose() +
                                lin.J_to * covariance.block<3, 3>(b, a) * lin.J_from.transpose() +
                                lin.J_to * covariance.block<3, 3>(b, b) * lin.J_to.transpose();
  const Eigen::LLT<Eigen::Matrix3d> llt(0.5 * (sigma + sigma.transpose()));
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  const double entropy = 0.5 * (3.0 * std::log(2.0 * M_PI * M_E) + log_det);
  const Eigen::Matrix3d information = llt.solve(Eigen::Matrix3d::Identity());
  return {i, j, -entropy, 0.5 * (information + information.transpose()), lin};
}

// A pair of blanket nodes and its Chow-Liu weight, what Kruskal sorts (a blanket of n nodes has
// n(n-1)/2 pairs: 694k for 1178 nodes; the tree's n-1 edges get their relative poses again).
struct Pair {
  std::size_t i;
  std::size_t j;
  double mutual_information_nats;
};

// Maximum spanning tree (Kruskal) over the pairs; ties keep the blanket order, so the result is
// deterministic.
std::vector<Pair> maximumSpanningTree(std::vector<Pair> pairs, std::size_t n) {
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.mutual_information_nats > b.mutual_information_nats;
  });
  std::vector<Pair> tree;
  UnionFind spanned(n);
  for (const Pair& p : pairs) {
    if (spanned.unite(p.i, p.j)) tree.push_back(p);
  }
  return tree;
}

// Conservative scaling: the tree's information over a piece (anchored at its root) against the
// marginal's. In the tree's own coordinates (its edges' relative poses, an invertible function
// of the non-root poses) the tree's information is block-diagonal, Omega = diag(Sigma_e^-1),
// and the marginal's covariance is Sigma_rel, whose diagonal blocks are the Sigma_e. Whitened,
// W = Omega^1/2 Sigma_rel Omega^1/2 (blocks L_e^T Sigma_rel(e, f) L_f, Omega_e = L_e L_e^T,
// identity on the diagonal). Scaling edge e's information by s_e (S = diag(s_e), one per 3x3
// block), the tree states no more than the marginal when S <= W^-1, i.e. when the largest
// eigenvalue of S^1/2 W S^1/2 is at most 1.
Eigen::MatrixXd whitenedCovariance(const Eigen::MatrixXd& covariance,
                                   const std::vector<Candidate*>& edges) {
  const auto size = static_cast<Eigen::Index>(3 * edges.size());
  std::vector<Eigen::Matrix3d> whitening;  // L_e
  for (const Candidate* c : edges) {
    whitening.push_back(Eigen::LLT<Eigen::Matrix3d>(c->information).matrixL());
  }
  auto block = [&](std::size_t a, std::size_t b) {
    return covariance.block<3, 3>(3 * static_cast<Eigen::Index>(a),
                                  3 * static_cast<Eigen::Index>(b));
  };
  Eigen::MatrixXd whitened(size, size);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const Candidate& ce = *edges[e];
    for (std::size_t f = e; f < edges.size(); ++f) {
      const Candidate& cf = *edges[f];
      const Eigen::Matrix3d sigma =
          ce.linearization.J_from * block(ce.i, cf.i) * cf.linearization.J_from.transpose() +
          ce.linearization.J_from * block(ce.i, cf.j) * cf.linearization.J_to.transpose() +
          ce.linearization.J_to * block(ce.j, cf.i) * cf.linearization.J_from.transpose() +
          ce.linearization.J_to * block(ce.j, cf.j) * cf.linearization.J_to.transpose();
      const Eigen::Matrix3d w = whitening[e].transpose() * sigma * whitening[f];
      whitened.block<3, 3>(3 * static_cast<Eigen::Index>(e), 3 * static_cast<Eigen::Index>(f)) = w;
      whitened.block<3, 3>(3 * static_cast<Eigen::Index>(f), 3 * static_cast<Eigen::Index>(e)) =
          w.transpose();
    }
  }
  return whitened;
}

// The scales s_e of a piece's edges (see above), from two that are conservative:
//   - one for all: 1 / lambda_max(W), the most the tree overstates the marginal's information
//     in any direction (at least 1; 1 only when the edges' relative poses are uncorrelated, the
//     marginal then being the tree itself);
//   - per edge (ChowLiuParams::per_edge_scaling), the Schur test: with N_ef = ||W_ef||_2,
//     s_e = 1 / sum_f N_ef. For any x, x^T S^1/2 W S^1/2 x <= y^T B y with y_e = ||x_e||,
//     B_ef = sqrt(s_e s_f) N_ef, and B p = p for p_e = sqrt(sum_f N_ef): the largest eigenvalue
//     is at most 1. An edge whose relative pose the others hardly correlate with keeps nearly
//     all its information, where the uniform scale divides every edge by the worst direction.
// The conservative scales form a convex set, so the segment between the two is conservative
// too; the point taken minimizes the piece's KL divergence in the tree's coordinates,
// 1/2 (tr(S W) - ln det(S W) - dim) = 3/2 sum_e (s_e - ln s_e) + const (W's diagonal blocks
// are I), a convex function of the segment's parameter.
std::vector<double> conservativeScales(const Eigen::MatrixXd& whitened, bool per_edge) {
  const auto edges = static_cast<std::size_t>(whitened.rows() / 3);
  const double uniform = 1.0 / std::max(1.0, largestEigenvalue(whitened));  // throws if not finite
  std::vector<double> scales(edges, uniform);
  if (!per_edge || edges < 2) return scales;
  Eigen::MatrixXd norms(edges, edges);  // N_ef = ||W_ef||_2
  for (std::size_t e = 0; e < edges; ++e) {
    for (std::size_t f = e; f < edges; ++f) {
      const Eigen::Matrix3d b =
          whitened.block<3, 3>(3 * static_cast<Eigen::Index>(e), 3 * static_cast<Eigen::Index>(f));
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> gram;
      gram.computeDirect(b.transpose() * b, Eigen::EigenvaluesOnly);
      norms(e, f) = norms(f, e) = std::sqrt(std::max(0.0, gram.eigenvalues()(2)));
    }
  }
  // The Schur test holds for any positive weights q, s_e = q_e / (N q)_e (q = 1 above; in
  // general B p = p for p_e = sqrt(q_e (N q)_e)); a few
  // rounds of q <- s, kept while they lower the loss, help large blankets (one of Intel's third
  // session, 250 nodes: KL 9.4 -> 8.2 of deletion's 13.2; the smaller ones do not move).
  auto loss = [](const Eigen::VectorXd& s) { return (s.array() - s.array().log()).sum(); };
  constexpr int kWeightRounds = 5;
  Eigen::VectorXd own_scales = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(edges));
  own_scales = own_scales.cwiseQuotient(norms * own_scales);
  for (int round = 0; round < kWeightRounds; ++round) {
    const Eigen::VectorXd next = own_scales.cwiseQuotient(norms * own_scales);
    if (loss(next) >= loss(own_scales)) break;
    own_scales = next;
  }
  // s(t) = (1 - t) uniform + t own; d/dt sum(s - ln s) = sum (1 - 1/s_e)(own_e - uniform),
  // increasing in t: bisection for its zero in [0, 1].
  auto slope = [&](double t) {
    double d = 0.0;
    for (std::size_t e = 0; e < edges; ++e) {
      const double own = own_scales(static_cast<Eigen::Index>(e));
      const double s = (1.0 - t) * uniform + t * own;
      d += (1.0 - 1.0 / s) * (own - uniform);
    }
    return d;
  };
  double lo = 0.0, hi = 1.0;
  if (slope(1.0) <= 0.0) {
    lo = 1.0;
  } else if (slope(0.0) < 0.0) {
    for (int k = 0; k < 60; ++k) {
      const double mid = 0.5 * (lo + hi);
      (slope(mid) < 0.0 ? lo : hi) = mid;
    }
  }
  for (std::size_t e = 0; e < edges; ++e) {
    scales[e] = (1.0 - lo) * uniform + lo * own_scales(static_cast<Eigen::Index>(e));
  }
  return scales;
}

// Scales each piece's tree edges by conservativeScales (Kruskal's order mixes pieces).
void makeConservative(const Eigen::MatrixXd& covariance,
                      const std::vector<std::vector<std::size_t>>& pieces, bool per_edge,
                      std::vector<Candidate>& tree) {
  std::vector<std::size_t> piece_of(covariance.rows() / 3, 0);
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    for (std::size_t k : pieces[p]) piece_of[k] = p;
  }
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    std::vector<Candidate*> edges;
    for (Candidate& c : tree) {
      if (piece_of[c.i] == p) edges.push_back(&c);
    }
    if (edges.empty()) continue;
    const std::vector<double> scales =
        conservativeScales(whitenedCovariance(covariance, edges), per_edge);
    for (std::size_t e = 0; e < edges.size(); ++e) edges[e]->information *= scales[e];
  }
}

// The largest rotation by which a gradient-matching measurement may differ from the relative pose
// at the linearization point (rad).
constexpr double kMaxOffsetRotation = M_PI / 2.0;

// Solves A^T v = g (see gradientMatchingConstraints) by the tree's structure: from the leaves to
// each piece's root, a node's equation J_p^T v_p + sum over its child edges J_c^T v_c = g_node
// gives its parent edge's v_p once its children's are known (J_p, J_c: the edges' 3x3 Jacobians
// at that node, invertible). O(n), where a dense LU of A was O(n^3). test_chow_liu checks that the
// tree's gradient is the marginal's.
Eigen::VectorXd treeTransposeSolve(const Marginal& marginal, const std::vector<Candidate>& tree,
                                   const std::vector<std::vector<std::size_t>>& pieces) {
  const std::size_t n = marginal.blanket.size();
  std::vector<std::vector<std::size_t>> incident(n);
  for (std::size_t e = 0; e < tree.size(); ++e) {
    incident[tree[e].i].push_back(e);
    incident[tree[e].j].push_back(e);
  }
  // Breadth first from each root: every other node's parent edge, parents before children.
  std::vector<std::size_t> order;
  std::vector<std::ptrdiff_t> parent_edge(n, -1);
  std::vector<char> reached(n, 0);
  for (const auto& piece : pieces) {
    const std::size_t first = order.size();
    order.push_back(piece.front());
    reached[piece.front()] = 1;
    for (std::size_t next = first; next < order.size(); ++next) {
      const std::size_t node = order[next];
      for (const std::size_t e : incident[node]) {
        const std::size_t other = tree[e].i == node ? tree[e].j : tree[e].i;
        if (reached[other]) continue;
        reached[other] = 1;
        parent_edge[other] = static_cast<std::ptrdiff_t>(e);
        order.push_back(other);
      }
    }
  }
  if (order.size() != n) throw std::logic_error("chowLiuTree: the tree does not span its pieces");
  std::vector<Eigen::Vector3d> rest(n);  // g_node minus what the solved child edges give
  for (std::size_t k = 0; k < n; ++k) {
    rest[k] = marginal.gradient.segment<3>(3 * static_cast<Eigen::Index>(k));
  }
  Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * tree.size()));
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const std::size_t node = *it;
    if (parent_edge[node] < 0) continue;  // a root: its equation holds with the others
    const auto e = static_cast<std::size_t>(parent_edge[node]);
    const Candidate& c = tree[e];
    const bool from = c.i == node;
    const Eigen::Matrix3d& J = from ? c.linearization.J_from : c.linearization.J_to;
    const Eigen::Vector3d v_e = J.transpose().partialPivLu().solve(rest[node]);
    v.segment<3>(3 * static_cast<Eigen::Index>(e)) = v_e;
    const std::size_t parent = from ? c.j : c.i;
    rest[parent] -= (from ? c.linearization.J_to : c.linearization.J_from).transpose() * v_e;
  }
  return v;
}

// The tree's edges as constraints whose gradient at the linearization point is the marginal's
// g. Edge e with measurement z_e = d_e - delta_e (d_e = between(x_i, x_j), on x, y, theta) has
// error K_z delta_e there, K_z = diag(R(z_theta)^T, 1), and Jacobians K_z K_d^T A_e with A_e its
// Jacobians at z_e = d_e; keeping the information A_e^T Omega_e A_e it held at d_e takes
// Q Omega_e Q^T, Q = K_z K_d^T = diag(R(delta_theta), 1), and its gradient is then
// A_e^T Omega_e K_d delta_e. Summed over the tree that must be g: A^T v = g with
// v_e = Omega_e K_d delta_e, A the tree's stacked Jacobians, square and invertible once each
// piece's root column is left out (a tree determines every pose from its root's); the root's
// equation then holds too, as both sides are orthogonal to the gauge.
std::vector<PoseConstraint> gradientMatchingConstraints(
    const Marginal& marginal, const std::vector<Candidate>& tree,
    const std::vector<std::vector<std::size_t>>& pieces) {
  const Eigen::VectorXd v = treeTransposeSolve(marginal, tree, pieces);

  // K_d delta_e per edge, then all offsets shrunk together where one would turn by more than
  // kMaxOffsetRotation (see ChowLiuParams::match_gradient): the tree's gradient is then c g, one
  // fraction c for the whole blanket (one per piece would not keep KL(tree) <= KL(delete): the
  // rest of the graph couples the pieces).
  std::vector<Eigen::Vector3d> k_deltas;
  double largest_rotation = 0.0;
  for (std::size_t e = 0; e < tree.size(); ++e) {
    k_deltas.push_back(
        tree[e].information.ldlt().solve(v.segment<3>(3 * static_cast<Eigen::Index>(e))));
    largest_rotation = std::max(largest_rotation, std::abs(k_deltas.back().z()));
  }
  const double fraction =
      largest_rotation > kMaxOffsetRotation ? kMaxOffsetRotation / largest_rotation : 1.0;
  std::vector<PoseConstraint> constraints;
  for (std::size_t e = 0; e < tree.size(); ++e) {
    const Candidate& c = tree[e];
    const Pose2 d = between(marginal.linearization_point[c.i], marginal.linearization_point[c.j]);
    const Eigen::Vector3d k_delta = fraction * k_deltas[e];
    Pose2 delta;
    delta.head<2>() = rotation(d.z()) * k_delta.head<2>();  // K_d^-1
    delta.z() = k_delta.z();
    const Pose2 z(d.x() - delta.x(), d.y() - delta.y(), normalizeAngle(d.z() - delta.z()));
    Eigen::Matrix3d Q = Eigen::Matrix3d::Identity();
    Q.topLeftCorner<2, 2>() = rotation(delta.z());
    const Eigen::Matrix3d information = Q * c.information * Q.transpose();
    constraints.push_back({marginal.blanket[c.i], marginal.blanket[c.j], z,
                           0.5 * (information + information.transpose())});
  }
  return constraints;
}

}  // namespace

std::vector<ChowLiuEdge> chowLiuTree(const Marginal& marginal, const ChowLiuParams& params) {
  checkMarginal(marginal);
  const std::vector<std::vector<std::size_t>> pieces = blanketPieces(marginal);
  const Eigen::MatrixXd covariance = anchoredCovariance(marginal, pieces);

  // Mutual information of every pair within a piece.
  std::vector<Pair> pairs;
  for (const auto& piece : pieces) {
    for (std::size_t a = 0; a < piece.size(); ++a) {
      for (std::size_t b = a + 1; b < piece.size(); ++b) {
        const Candidate c = relativePose(marginal, covariance, piece[a], piece[b]);
        pairs.push_back({c.i, c.j, c.mutual_information_nats});
      }
    }
  }
  std::vector<Candidate> tree;
  for (const Pair& p : maximumSpanningTree(std::move(pairs), marginal.blanket.size())) {
    tree.push_back(relativePose(marginal, covariance, p.i, p.j));
  }
  if (params.conservative) makeConservative(covariance, pieces, params.per_edge_scaling, tree);

  std::vector<ChowLiuEdge> edges;
  if (params.match_gradient) {
    const std::vector<PoseConstraint> constraints =
        gradientMatchingConstraints(marginal, tree, pieces);
    for (std::size_t e = 0; e < tree.size(); ++e) {
      edges.push_back({constraints[e], tree[e].mutual_information_nats});
    }
    return edges;
  }
  for (const Candidate& c : tree) {
    const Pose2& x_i = marginal.linearization_point[c.i];
    const Pose2& x_j = marginal.linearization_point[c.j];
    edges.push_back(
        {{marginal.blanket[c.i], marginal.blanket[c.j], between(x_i, x_j), c.information},
         c.mutual_information_nats});
  }
  return edges;
}

QuadraticModel replacementModel(const Marginal& marginal, MarginalReplacement replacement,
                                const ChowLiuParams& params) {
  switch (replacement) {
    case MarginalReplacement::kChowLiuTree: {
      std::vector<PoseConstraint> constraints;
      for (const ChowLiuEdge& edge : chowLiuTree(marginal, params)) {
        constraints.push_back(edge.constraint);
      }
      return linearizeConstraints(constraints, marginal.blanket, marginal.linearization_point);
    }
    case MarginalReplacement::kDense:
      return {marginal.information, marginal.gradient, marginal.chi2_at_linearization};
    case MarginalReplacement::kDelete:
      break;
  }
  const auto size = static_cast<Eigen::Index>(3 * marginal.blanket.size());
  return {Eigen::MatrixXd::Zero(size, size), Eigen::VectorXd::Zero(size), 0.0};
}

}  // namespace rrr_graphslam::core
