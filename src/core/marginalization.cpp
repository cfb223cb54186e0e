#include "rrr_graphslam/core/marginalization.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/core/sparse_solver.h"
#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::core {
namespace {

// M, its Markov blanket B and the constraints touching M, checked. Local variable order: the
// removed nodes (increasing ids), then the blanket nodes (increasing ids).
struct LocalProblem {
  std::vector<NodeId> removed;
  std::vector<NodeId> blanket;
  std::vector<Pose2> removed_poses;
  std::vector<Pose2> blanket_poses;
  std::vector<std::size_t> constraint_indices;  // into the caller's constraints
  std::vector<PoseConstraint> constraints;      // the constraints touching M
  std::vector<std::size_t> factor_indices;      // into the caller's dense factors
  std::vector<DenseFactor> factors;             // the dense factors holding a node of M
};

std::string invalid(const std::string& what) { return "marginalizeNodes: " + what; }

std::string describe(std::size_t k, const PoseConstraint& c) {
  return "constraint " + std::to_string(k) + " (" + std::to_string(c.from) + " -> " +
         std::to_string(c.to) + ")";
}

// Markov blanket: checks the input and collects M, B and the constraints touching M.
LocalProblem markovBlanket(const std::vector<PoseConstraint>& constraints,
                           const std::vector<DenseFactor>& factors,
                           const std::map<NodeId, Pose2>& poses,
                           const std::vector<NodeId>& removed) {
  LocalProblem p;
  if (removed.empty()) throw std::invalid_argument(invalid("no nodes to marginalize"));
  p.removed = removed;
  std::sort(p.removed.begin(), p.removed.end());
  const auto twice = std::adjacent_find(p.removed.begin(), p.removed.end());
  if (twice != p.removed.end()) {
    throw std::invalid_argument(invalid("node " + std::to_string(*twice) + " is listed twice"));
  }
  auto isRemoved = [&](NodeId id) {
    return std::binary_search(p.removed.begin(), p.removed.end(), id);
  };
  auto poseOf = [&](NodeId id) {
    const Pose2& pose = poses.at(id);
    const std::string problem = poseProblem(pose);
    if (!problem.empty()) {
      throw std::invalid_argument(invalid("node " + std::to_string(id) + ": pose " + problem));
    }
    return pose;
  };
  for (NodeId id : p.removed) {
    if (poses.count(id) == 0) {
      throw std::invalid_argument(
          invalid("node " + std::to_string(id) + " is unknown (no pose given)"));
    }
    p.removed_poses.push_back(poseOf(id));
  }

  for (std::size_t k = 0; k < constraints.size(); ++k) {
    const PoseConstraint& c = constraints[k];
    const bool from_removed = isRemoved(c.from), to_removed = isRemoved(c.to);
    if (!from_removed && !to_removed) continue;
    if (c.from == c.to) {
      throw std::invalid_argument(invalid(describe(k, c) + " is a self-loop"));
    }
    const std::string measurement_problem = poseProblem(c.measurement);
    if (!measurement_problem.empty()) {
      throw std::invalid_argument(invalid(describe(k, c) + ": measurement " + measurement_problem));
    }
    const std::string information_problem = informationProblem(c.information);
    if (!information_problem.empty()) {
      throw std::invalid_argument(invalid(describe(k, c) + ": information " + information_problem));
    }
    for (NodeId end : {c.from, c.to}) {
      if (poses.count(end) == 0) {
        throw std::invalid_argument(
            invalid(describe(k, c) + " joins node " + std::to_string(end) + ", which has no pose"));
      }
    }
    if (!from_removed) p.blanket.push_back(c.from);
    if (!to_removed) p.blanket.push_back(c.to);
    p.constraint_indices.push_back(k);
    p.constraints.push_back(c);
  }
  for (std::size_t f = 0; f < factors.size(); ++f) {
    const DenseFactor& factor = factors[f];
    if (std::none_of(factor.nodes.begin(), factor.nodes.end(), isRemoved)) continue;
    const std::string problem = denseFactorProblem(factor);
    if (!problem.empty()) {
      throw std::invalid_argument(invalid("dense factor " + std::to_string(f) + ": " + problem));
    }
    for (NodeId id : factor.nodes) {
      if (poses.count(id) == 0) {
        throw std::invalid_argument(invalid("dense factor " + std::to_string(f) + " holds node " +
                                            std::to_string(id) + ", which has no pose"));
      }
      if (!isRemoved(id)) p.blanket.push_back(id);
    }
    p.factor_indices.push_back(f);
    p.factors.push_back(factor);
  }
  std::sort(p.blanket.begin(), p.blanket.end());
  p.blanket.erase(std::unique(p.blanket.begin(), p.blanket.end()), p.blanket.end());
  for (NodeId id : p.blanket) p.blanket_poses.push_back(poseOf(id));

  // Connected pieces of M and B through the constraints touching M: each piece of M must reach
  // B, or Lambda_MM is singular (the piece can move freely as a rigid body).
  const std::size_t m = p.removed.size();
  auto local = [&](NodeId id) {
    const auto r = std::lower_bound(p.removed.begin(), p.removed.end(), id);
    if (r != p.removed.end() && *r == id) return static_cast<std::size_t>(r - p.removed.begin());
    return m + static_cast<std::size_t>(std::lower_bound(p.blanket.begin(), p.blanket.end(), id) -
                                        p.blanket.begin());
  };
  UnionFind pieces(m + p.blanket.size());
  for (const PoseConstraint& c : p.constraints) pieces.unite(local(c.from), local(c.to));
  for (const DenseFactor& f : p.factors) {
    for (NodeId id : f.nodes) pieces.unite(local(f.nodes.front()), local(id));
  }
  std::vector<char> reaches_blanket(m + p.blanket.size(), 0);
  for (std::size_t j = 0; j < p.blanket.size(); ++j) reaches_blanket[pieces.find(m + j)] = 1;
  for (std::size_t i = 0; i < m; ++i) {
    if (!reaches_blanket[pieces.find(i)]) {
      throw std::invalid_argument(
          invalid("node " + std::to_string(p.removed[i]) +
                  " (with the removed nodes connected to it) has no constraint to a kept node: "
                  "Lambda_MM is singular, the piece being free to move as a rigid body; it holds "
                  "no information about the kept nodes, so delete it with its constraints"));
    }
  }
  return p;
}

// Fills the result from the Schur complement's parts (symmetrized against rounding).
Marginal makeMarginal(LocalProblem&& p, const Eigen::MatrixXd& information,
                      Eigen::VectorXd gradient, double chi2) {
  Marginal out;
  out.information = 0.5 * (information + information.transpose());
  out.gradient = std::move(gradient);
  out.chi2_at_linearization = chi2;
  out.removed_nodes = std::move(p.removed);
  out.removed_constraints = std::move(p.constraint_indices);
  out.removed_factors = std::move(p.factor_indices);
  out.blanket = std::move(p.blanket);
  out.linearization_point = std::move(p.blanket_poses);
  return out;
}

const char* const kNotPositiveDefinite =
    "Lambda_MM is not positive definite (numerically singular: information matrices too far "
    "apart in scale?)";

}  // namespace

Marginal marginalizeNodes(const std::vector<PoseConstraint>& constraints,
                          const std::map<NodeId, Pose2>& poses,
                          const std::vector<NodeId>& removed) {
  return marginalizeNodes(constraints, {}, poses, removed);
}

Marginal marginalizeNodes(const std::vector<PoseConstraint>& constraints,
                          const std::vector<DenseFactor>& factors,
                          const std::map<NodeId, Pose2>& poses,
                          const std::vector<NodeId>& removed) {
  LocalProblem p = markovBlanket(constraints, factors, poses, removed);
  const auto m = static_cast<Eigen::Index>(p.removed.size());
  const auto b = static_cast<Eigen::Index>(p.blanket.size());

  // Linearization, sparse in M: Lambda_MM (upper triangle) and Lambda_MB as triplets,
  // Lambda_BB dense (the blanket is small and its marginal is dense anyway).
  std::vector<Eigen::Triplet<double, int>> mm, mb;
  Eigen::MatrixXd lambda_bb = Eigen::MatrixXd::Zero(3 * b, 3 * b);
  Eigen::VectorXd g_m = Eigen::VectorXd::Zero(3 * m), g_b = Eigen::VectorXd::Zero(3 * b);
  double chi2 = 0.0;
  struct End {
    bool removed;
    Eigen::Index index;  // among M or among B
    const Eigen::Matrix3d* J;
  };
  auto endOf = [&](NodeId id, const Eigen::Matrix3d& J) {
    const auto r = std::lower_bound(p.removed.begin(), p.removed.end(), id);
    if (r != p.removed.end() && *r == id) return End{true, r - p.removed.begin(), &J};
    return End{false, std::lower_bound(p.blanket.begin(), p.blanket.end(), id) - p.blanket.begin(),
               &J};
  };
  // Block (row, col) of Lambda into its part: MM (upper triangle), MB, BB (BM is MB^T).
  auto addBlock = [&](const End& row, const End& col, const Eigen::Matrix3d& block) {
    if (row.removed && col.removed) {
      for (int r = 0; r < 3; ++r) {
        for (int q = 0; q < 3; ++q) {
          const Eigen::Index i = 3 * row.index + r, j = 3 * col.index + q;
          if (i <= j) mm.emplace_back(static_cast<int>(i), static_cast<int>(j), block(r, q));
        }
      }
    } else if (row.removed) {
      for (int r = 0; r < 3; ++r) {
        for (int q = 0; q < 3; ++q) {
          mb.emplace_back(static_cast<int>(3 * row.index + r), static_cast<int>(3 * col.index + q),
                          block(r, q));
        }
      }
    } else if (!col.removed) {
      lambda_bb.block<3, 3>(3 * row.index, 3 * col.index) += block;
    }  // (blanket, removed) is Lambda_BM = Lambda_MB^T: not stored
  };
  for (const PoseConstraint& c : p.constraints) {
    const EdgeLinearization lin = linearizeEdge(poses.at(c.from), poses.at(c.to), c.measurement);
    const std::array<End, 2> ends{endOf(c.from, lin.J_from), endOf(c.to, lin.J_to)};
    for (const End& e : ends) {
      const Eigen::Vector3d g = e.J->transpose() * c.information * lin.error;
      (e.removed ? g_m : g_b).segment<3>(3 * e.index) += g;
    }
    chi2 += lin.error.dot(c.information * lin.error);
    for (const End& row : ends) {
      for (const End& col : ends) addBlock(row, col, row.J->transpose() * c.information * *col.J);
    }
  }
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  for (const DenseFactor& f : p.factors) {
    std::vector<Pose2> at;
    for (NodeId id : f.nodes) at.push_back(poses.at(id));
    const DenseFactorLinearization lin = linearize(f, at);
    chi2 += lin.chi2;
    std::vector<End> ends;
    for (NodeId id : f.nodes) ends.push_back(endOf(id, identity));
    for (std::size_t i = 0; i < ends.size(); ++i) {
      const auto fi = static_cast<Eigen::Index>(3 * i);
      (ends[i].removed ? g_m : g_b).segment<3>(3 * ends[i].index) += lin.gradient.segment<3>(fi);
      for (std::size_t j = 0; j < ends.size(); ++j) {
        addBlock(ends[i], ends[j],
                 lin.information.block<3, 3>(fi, static_cast<Eigen::Index>(3 * j)));
      }
    }
  }
  SparseSolver::Matrix lambda_mm(3 * m, 3 * m), lambda_mb(3 * m, 3 * b);
  lambda_mm.setFromTriplets(mm.begin(), mm.end());  // duplicates are summed
  lambda_mb.setFromTriplets(mb.begin(), mb.end());
  lambda_mm.makeCompressed();

  // Schur complement over M with CHOLMOD's factor of Lambda_MM.
  SparseSolver solver;
  solver.analyze(lambda_mm);
  if (!solver.factorize(lambda_mm)) throw std::invalid_argument(invalid(kNotPositiveDefinite));
  const Eigen::MatrixXd x = solver.solve(Eigen::MatrixXd(lambda_mb));  // Lambda_MM^-1 Lambda_MB
  const Eigen::VectorXd y = solver.solve(g_m);                         // Lambda_MM^-1 g_M
  Eigen::MatrixXd information = lambda_bb;
  information.noalias() -= lambda_mb.transpose() * x;
  Eigen::VectorXd gradient = g_b;
  gradient.noalias() -= lambda_mb.transpose() * y;
  return makeMarginal(std::move(p), information, std::move(gradient), chi2 - g_m.dot(y));
}

Marginal marginalizeNodes(const PoseGraph& graph, const std::vector<NodeId>& removed) {
  std::map<NodeId, Pose2> poses;
  for (NodeId id : graph.nodeIds()) poses.emplace(id, graph.pose(id));
  return marginalizeNodes(constraintsOf(graph), graph.denseFactors(), poses, removed);
}

Marginal marginalizeNodesDense(const std::vector<PoseConstraint>& constraints,
                               const std::map<NodeId, Pose2>& poses,
                               const std::vector<NodeId>& removed) {
  return marginalizeNodesDense(constraints, {}, poses, removed);
}

Marginal marginalizeNodesDense(const std::vector<PoseConstraint>& constraints,
                               const std::vector<DenseFactor>& factors,
                               const std::map<NodeId, Pose2>& poses,
                               const std::vector<NodeId>& removed) {
  LocalProblem p = markovBlanket(constraints, factors, poses, removed);
  std::vector<NodeId> nodes = p.removed;
  nodes.insert(nodes.end(), p.blanket.begin(), p.blanket.end());
  std::vector<Pose2> at = p.removed_poses;
  at.insert(at.end(), p.blanket_poses.begin(), p.blanket_poses.end());
  const QuadraticModel model = linearizeConstraints(p.constraints, p.factors, nodes, at);

  const auto m = static_cast<Eigen::Index>(3 * p.removed.size());
  const auto b = static_cast<Eigen::Index>(3 * p.blanket.size());
  const Eigen::LLT<Eigen::MatrixXd> lambda_mm(model.information.topLeftCorner(m, m));
  if (lambda_mm.info() != Eigen::Success) {
    throw std::invalid_argument(invalid(kNotPositiveDefinite));
  }
  const Eigen::MatrixXd lambda_mb = model.information.topRightCorner(m, b);
  const Eigen::VectorXd g_m = model.gradient.head(m);
  const Eigen::VectorXd y = lambda_mm.solve(g_m);
  Eigen::MatrixXd information = model.information.bottomRightCorner(b, b) -
                                lambda_mb.transpose() * lambda_mm.solve(lambda_mb);
  Eigen::VectorXd gradient = model.gradient.tail(b) - lambda_mb.transpose() * y;
  return makeMarginal(std::move(p), information, std::move(gradient),
                      model.chi2_at_linearization - g_m.dot(y));
}

std::vector<std::vector<std::size_t>> blanketPieces(const Marginal& marginal) {
  const std::size_t n = marginal.blanket.size();
  UnionFind pieces(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const auto a = static_cast<Eigen::Index>(3 * i), b = static_cast<Eigen::Index>(3 * j);
      if (!marginal.information.block<3, 3>(a, b).isZero(0.0)) pieces.unite(i, j);
    }
  }
  std::vector<std::vector<std::size_t>> members(n);
  for (std::size_t i = 0; i < n; ++i) members[pieces.find(i)].push_back(i);
  members.erase(std::remove_if(members.begin(), members.end(),
                               [](const std::vector<std::size_t>& m) { return m.empty(); }),
                members.end());
  return members;
}

std::vector<DenseFactor> denseFactors(const Marginal& marginal) {
  std::vector<DenseFactor> factors;
  double offset = marginal.chi2_at_linearization;
  for (const std::vector<std::size_t>& piece : blanketPieces(marginal)) {
    if (piece.size() < 2) continue;
    const std::size_t root = piece.front();
    const Pose2& x_root = marginal.linearization_point[root];
    const auto k = static_cast<Eigen::Index>(piece.size() - 1);
    DenseFactor f;
    f.nodes.push_back(marginal.blanket[root]);
    std::vector<Eigen::Index> rows;
    Eigen::MatrixXd j_inverse = Eigen::MatrixXd::Zero(3 * k, 3 * k);  // blockdiag(J_to^-1)
    for (std::size_t a = 1; a < piece.size(); ++a) {
      const Pose2& x_a = marginal.linearization_point[piece[a]];
      f.nodes.push_back(marginal.blanket[piece[a]]);
      f.measurements.push_back(between(x_root, x_a));
      const EdgeLinearization lin = linearizeEdge(x_root, x_a, f.measurements.back());
      const auto at = static_cast<Eigen::Index>(3 * (a - 1));
      j_inverse.block<3, 3>(at, at) = lin.J_to.inverse();  // a rotation: always invertible
      for (int q = 0; q < 3; ++q) rows.push_back(3 * static_cast<Eigen::Index>(piece[a]) + q);
    }
    // Over the errors: Omega = J^-T Lambda_oo J^-1, h = J^-T g_o (the root held: the gauge).
    const Eigen::MatrixXd product =
        j_inverse.transpose() * marginal.information(rows, rows) * j_inverse;
    Eigen::MatrixXd omega = 0.5 * (product + product.transpose());  // exactly symmetric
    const Eigen::VectorXd h = j_inverse.transpose() * marginal.gradient(rows);
    const Eigen::LLT<Eigen::MatrixXd> llt(omega);
    if (llt.info() != Eigen::Success) {
      std::string ids;
      for (std::size_t b : piece)
        ids += (ids.empty() ? "" : ", ") + std::to_string(marginal.blanket[b]);
      throw std::invalid_argument("denseFactors: the marginal over blanket nodes {" + ids +
                                  "} is singular beyond its gauge (node " +
                                  std::to_string(marginal.blanket[root]) +
                                  " anchored): some relative pose carries no information");
    }
    f.mean = -llt.solve(h);
    f.information = std::move(omega);
    offset += h.dot(f.mean);  // - h^T Omega^-1 h
    factors.push_back(std::move(f));
  }
  // The removed chi2 at the factors' minimum is the marginal's, whichever piece it came from:
  // kept on the first factor (pieces are independent, so only the sum has a meaning). Rounding
  // can take a zero minimum a hair below zero.
  if (!factors.empty()) factors.front().chi2_offset = std::max(0.0, offset);
  return factors;
}

double marginalChi2(const Marginal& marginal, const std::vector<Pose2>& blanket_poses) {
  const Eigen::VectorXd dx = perturbation(blanket_poses, marginal.linearization_point);
  return marginal.chi2_at_linearization + 2.0 * marginal.gradient.dot(dx) +
         dx.dot(marginal.information * dx);
}

}  // namespace rrr_graphslam::core
