// Optimizer, marginal covariances: from the last undamped factorization (SparseSolver's partial
// inverse), propagated along odometry to the nodes added since.

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Dense>

#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {

bool Optimizer::nodesAddedAsTree(std::vector<int>& parent) const {
  parent.assign(static_cast<std::size_t>(numNodes() - factored_nodes_), -1);
  for (int k = factored_constraints_; k < numConstraints(); ++k) {
    if (!active_[static_cast<std::size_t>(k)]) continue;
    const int newer = std::max(from(k), to(k)) - factored_nodes_;
    if (newer < 0 || parent[static_cast<std::size_t>(newer)] >= 0) return false;
    parent[static_cast<std::size_t>(newer)] = k;
  }
  // A node without one starts a new session, held only by its weak anchor.
  return std::find(parent.begin(), parent.end(), -1) == parent.end();
}

Eigen::MatrixXd Optimizer::factorCovariance(const std::vector<int>& nodes) const {
  // Fixed nodes have no variable and zero covariance.
  std::vector<int> rows, at;
  for (std::size_t a = 0; a < nodes.size(); ++a) {
    const int v = variable_of_node_[static_cast<std::size_t>(nodes[a])];
    if (v < 0) continue;
    for (int r = 0; r < 3; ++r) {
      rows.push_back(3 * v + r);
      at.push_back(3 * static_cast<int>(a) + r);
    }
  }
  const Eigen::MatrixXd inverse = solver_.inverseSubmatrix(rows);
  const auto m = static_cast<Eigen::Index>(nodes.size());
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(3 * m, 3 * m);
  for (std::size_t a = 0; a < at.size(); ++a) {
    for (std::size_t b = 0; b < at.size(); ++b) {
      out(at[a], at[b]) = inverse(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
    }
  }
  return out;
}

bool Optimizer::factorAtCurrentPoses() {
  prepareStructure();
  chooseAnchors();
  covariance_valid_ = false;
  factor_valid_ = false;
  if (used_variables_ == 0 || !std::isfinite(assemble())) return false;
  covariance_valid_ = solver_.factorize(hessian_.matrix());
  if (covariance_valid_) rememberFactoredState();
  return covariance_valid_;
}

Eigen::MatrixXd Optimizer::covariance(const std::vector<int>& nodes) const {
  for (int n : nodes) {
    if (n < 0 || n >= numNodes()) {
      throw std::out_of_range("Optimizer::covariance: no node " + std::to_string(n) + " (of " +
                              std::to_string(numNodes()) + ")");
    }
  }
  const auto m = static_cast<Eigen::Index>(nodes.size());
  std::vector<int> parent;
  if (!covariance_valid_ || !nodesAddedAsTree(parent)) return Eigen::MatrixXd::Zero(3 * m, 3 * m);
  auto other_end = [&](int constraint, int node) {
    return from(constraint) == node ? to(constraint) : from(constraint);
  };
  // The tree nodes needed: the requested ones and their ancestors, down to factored nodes.
  const auto added = parent.size();
  std::vector<char> needed(added, 0), requested(added, 0);
  std::vector<int> pending_children(added, 0);
  std::vector<int> kept;  // nodes whose joint covariance `sigma` holds, in its order
  for (int n : nodes) {
    if (n >= factored_nodes_) {
      needed[static_cast<std::size_t>(n - factored_nodes_)] = 1;
      requested[static_cast<std::size_t>(n - factored_nodes_)] = 1;
    } else {
      kept.push_back(n);
    }
  }
  for (std::size_t k = added; k-- > 0;) {
    if (!needed[k]) continue;
    const int p = other_end(parent[k], factored_nodes_ + static_cast<int>(k));
    if (p >= factored_nodes_) {
      needed[static_cast<std::size_t>(p - factored_nodes_)] = 1;
      ++pending_children[static_cast<std::size_t>(p - factored_nodes_)];
    } else {
      kept.push_back(p);
    }
  }
  std::sort(kept.begin(), kept.end());
  kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
  Eigen::MatrixXd sigma = factorCovariance(kept);

  auto position = [&](int node) {
    return 3 * static_cast<Eigen::Index>(std::find(kept.begin(), kept.end(), node) - kept.begin());
  };
  // Down the tree: a node hanging from p by e(x_p, x_n) = J_p dx_p + J_n dx_n + noise has
  // dx_n = A dx_p + w, A = -J_n^-1 J_p, cov(w) = J_n^-1 (w Omega)^-1 J_n^-T.
  for (std::size_t k = 0; k < added; ++k) {
    if (!needed[k]) continue;
    const int node = factored_nodes_ + static_cast<int>(k);
    const auto c = static_cast<std::size_t>(parent[k]);
    const int p = other_end(parent[k], node);
    const Constraint& con = constraints_[c];
    const EdgeLinearization lin =
        linearizeEdge(poses_[static_cast<std::size_t>(con.from)],
                      poses_[static_cast<std::size_t>(con.to)], con.measurement);
    const bool node_is_to = con.to == node;
    const Eigen::Matrix3d J_node_inverse = (node_is_to ? lin.J_to : lin.J_from).inverse();
    const Eigen::Matrix3d A = -J_node_inverse * (node_is_to ? lin.J_from : lin.J_to);
    const Eigen::Matrix3d Q =
        J_node_inverse * (weight_[c] * con.information).inverse() * J_node_inverse.transpose();
    const Eigen::Index at = position(p), size = sigma.rows();
    const Eigen::MatrixXd cross = A * sigma.middleRows(at, 3);  // 3 x size
    const Eigen::Matrix3d own = A * sigma.block<3, 3>(at, at) * A.transpose() + Q;
    sigma.conservativeResize(size + 3, size + 3);
    sigma.bottomLeftCorner(3, size) = cross;
    sigma.topRightCorner(size, 3) = cross.transpose();
    sigma.bottomRightCorner<3, 3>() = 0.5 * (own + own.transpose());
    kept.push_back(node);
    // A parent no longer needed leaves sigma, which stays as small as the request.
    if (p >= factored_nodes_) {
      const auto q = static_cast<std::size_t>(p - factored_nodes_);
      if (--pending_children[q] == 0 && !requested[q]) {
        std::vector<Eigen::Index> rows;
        for (Eigen::Index r = 0; r < sigma.rows(); ++r) {
          if (r / 3 != at / 3) rows.push_back(r);
        }
        sigma = Eigen::MatrixXd(sigma(rows, rows));
        kept.erase(kept.begin() + at / 3);
      }
    }
  }

  Eigen::MatrixXd out(3 * m, 3 * m);
  for (Eigen::Index a = 0; a < m; ++a) {
    for (Eigen::Index b = 0; b < m; ++b) {
      out.block<3, 3>(3 * a, 3 * b) =
          sigma.block<3, 3>(position(nodes[static_cast<std::size_t>(a)]),
                            position(nodes[static_cast<std::size_t>(b)]));
    }
  }
  return out;
}

Eigen::MatrixXd Optimizer::projectedCovariance(const std::vector<JacobianBlock>& J,
                                               int rows) const {
  if (rows < 0) {
    throw std::out_of_range("Optimizer::projectedCovariance: " + std::to_string(rows) + " rows");
  }
  std::vector<int> nodes;
  for (const JacobianBlock& b : J) {
    if (b.row < 0 || b.row >= rows) {
      throw std::out_of_range("Optimizer::projectedCovariance: a block in row " +
                              std::to_string(b.row) + " of " + std::to_string(rows));
    }
    nodes.push_back(b.node);
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  const auto m = 3 * static_cast<Eigen::Index>(rows);
  if (!nodes.empty() && (nodes.front() < 0 || nodes.back() >= numNodes())) {
    throw std::out_of_range("Optimizer::projectedCovariance: no node " +
                            std::to_string(nodes.front() < 0 ? nodes.front() : nodes.back()) +
                            " (of " + std::to_string(numNodes()) + ")");
  }
  if (!covarianceAvailable()) return Eigen::MatrixXd::Zero(m, m);
  if (!nodes.empty() && nodes.back() >= factored_nodes_) {
    // Nodes added since the factorization: through their joint covariance (propagated).
    auto column = [&](int node) {
      return 3 * static_cast<Eigen::Index>(std::lower_bound(nodes.begin(), nodes.end(), node) -
                                           nodes.begin());
    };
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(m, 3 * static_cast<Eigen::Index>(nodes.size()));
    for (const JacobianBlock& b : J) dense.block<3, 3>(3 * b.row, column(b.node)) += b.value;
    return dense * covariance(nodes) * dense.transpose();
  }
  // B = J' on the factor's variables; fixed nodes have none (zero covariance).
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(9 * J.size());
  for (const JacobianBlock& b : J) {
    const int v = variable_of_node_[static_cast<std::size_t>(b.node)];
    if (v < 0) continue;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) entries.emplace_back(3 * v + c, 3 * b.row + r, b.value(r, c));
    }
  }
  SparseSolver::Matrix B(solver_.dimension(), m);
  B.setFromTriplets(entries.begin(), entries.end());  // repeated blocks add up
  return solver_.inverseProjection(B);
}

Eigen::SparseMatrix<double> Optimizer::informationMatrix() const {
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    if (!active_[k]) continue;
    const Constraint& c = constraints_[k];
    const EdgeLinearization lin =
        linearizeEdge(poses_[static_cast<std::size_t>(c.from)],
                      poses_[static_cast<std::size_t>(c.to)], c.measurement);
    const Eigen::Matrix3d omega = weight_[k] * c.information;
    const std::array<std::pair<int, const Eigen::Matrix3d*>, 2> ends{
        {{c.from, &lin.J_from}, {c.to, &lin.J_to}}};
    for (const auto& [a, Ja] : ends) {
      for (const auto& [b, Jb] : ends) {
        const Eigen::Matrix3d block = Ja->transpose() * omega * *Jb;
        for (int r = 0; r < 3; ++r) {
          for (int q = 0; q < 3; ++q) entries.emplace_back(3 * a + r, 3 * b + q, block(r, q));
        }
      }
    }
  }
  std::vector<Pose2> at;
  for (const Dense& d : dense_) {
    at.clear();
    for (int n : d.nodes) at.push_back(poses_[static_cast<std::size_t>(n)]);
    const Eigen::MatrixXd info = linearize(d.factor, at).information;
    for (std::size_t i = 0; i < d.nodes.size(); ++i) {
      for (std::size_t j = 0; j < d.nodes.size(); ++j) {
        for (int r = 0; r < 3; ++r) {
          for (int q = 0; q < 3; ++q) {
            entries.emplace_back(
                3 * d.nodes[i] + r, 3 * d.nodes[j] + q,
                info(static_cast<Eigen::Index>(3 * i + r), static_cast<Eigen::Index>(3 * j + q)));
          }
        }
      }
    }
  }
  Eigen::SparseMatrix<double> H(3 * numNodes(), 3 * numNodes());
  H.setFromTriplets(entries.begin(), entries.end());  // duplicates are summed
  return H;
}

}  // namespace rrr_graphslam::core
