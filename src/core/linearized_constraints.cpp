#include "rrr_graphslam/core/linearized_constraints.h"

#include <stdexcept>
#include <string>
#include <unordered_map>

namespace rrr_graphslam::core {

QuadraticModel linearizeConstraints(const std::vector<PoseConstraint>& constraints,
                                    const std::vector<NodeId>& nodes,
                                    const std::vector<Pose2>& poses) {
  return linearizeConstraints(constraints, {}, nodes, poses);
}

QuadraticModel linearizeConstraints(const std::vector<PoseConstraint>& constraints,
                                    const std::vector<DenseFactor>& factors,
                                    const std::vector<NodeId>& nodes,
                                    const std::vector<Pose2>& poses) {
  if (poses.size() != nodes.size()) {
    throw std::invalid_argument("linearizeConstraints: " + std::to_string(nodes.size()) +
                                " nodes but " + std::to_string(poses.size()) + " poses");
  }
  std::unordered_map<NodeId, Eigen::Index> index;
  for (std::size_t k = 0; k < nodes.size(); ++k) index[nodes[k]] = static_cast<Eigen::Index>(k);
  auto indexOf = [&](NodeId id, std::size_t constraint) {
    const auto it = index.find(id);
    if (it == index.end()) {
      throw std::invalid_argument("linearizeConstraints: constraint " + std::to_string(constraint) +
                                  " joins node " + std::to_string(id) +
                                  ", which is not among the nodes given");
    }
    return it->second;
  };

  const auto n = static_cast<Eigen::Index>(3 * nodes.size());
  QuadraticModel model;
  model.information = Eigen::MatrixXd::Zero(n, n);
  model.gradient = Eigen::VectorXd::Zero(n);
  for (std::size_t k = 0; k < constraints.size(); ++k) {
    const PoseConstraint& c = constraints[k];
    const Eigen::Index a = indexOf(c.from, k), b = indexOf(c.to, k);
    const EdgeLinearization lin = linearizeEdge(poses[static_cast<std::size_t>(a)],
                                                poses[static_cast<std::size_t>(b)], c.measurement);
    const Eigen::Matrix3d& omega = c.information;
    model.information.block<3, 3>(3 * a, 3 * a) += lin.J_from.transpose() * omega * lin.J_from;
    model.information.block<3, 3>(3 * a, 3 * b) += lin.J_from.transpose() * omega * lin.J_to;
    model.information.block<3, 3>(3 * b, 3 * a) += lin.J_to.transpose() * omega * lin.J_from;
    model.information.block<3, 3>(3 * b, 3 * b) += lin.J_to.transpose() * omega * lin.J_to;
    model.gradient.segment<3>(3 * a) += lin.J_from.transpose() * omega * lin.error;
    model.gradient.segment<3>(3 * b) += lin.J_to.transpose() * omega * lin.error;
    model.chi2_at_linearization += lin.error.dot(omega * lin.error);
  }
  for (std::size_t f = 0; f < factors.size(); ++f) {
    const DenseFactor& factor = factors[f];
    std::vector<Eigen::Index> at;
    std::vector<Pose2> factor_poses;
    for (NodeId id : factor.nodes) {
      const auto it = index.find(id);
      if (it == index.end()) {
        throw std::invalid_argument("linearizeConstraints: dense factor " + std::to_string(f) +
                                    " holds node " + std::to_string(id) +
                                    ", which is not among the nodes given");
      }
      at.push_back(it->second);
      factor_poses.push_back(poses[static_cast<std::size_t>(it->second)]);
    }
    const DenseFactorLinearization lin = linearize(factor, factor_poses);
    for (std::size_t i = 0; i < at.size(); ++i) {
      const auto fi = static_cast<Eigen::Index>(3 * i);
      model.gradient.segment<3>(3 * at[i]) += lin.gradient.segment<3>(fi);
      for (std::size_t j = 0; j < at.size(); ++j) {
        model.information.block<3, 3>(3 * at[i], 3 * at[j]) +=
            lin.information.block<3, 3>(fi, static_cast<Eigen::Index>(3 * j));
      }
    }
    model.chi2_at_linearization += lin.chi2;
  }
  return model;
}

std::vector<PoseConstraint> constraintsOf(const PoseGraph& graph) {
  std::vector<PoseConstraint> constraints;
  constraints.reserve(graph.numEdges());
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const PoseGraph::Edge& e = graph.edge(k);
    constraints.push_back({e.from, e.to, graph.measurement(k), graph.information(k)});
  }
  return constraints;
}

Eigen::VectorXd perturbation(const std::vector<Pose2>& x, const std::vector<Pose2>& x0) {
  if (x.size() != x0.size()) {
    throw std::invalid_argument("perturbation: " + std::to_string(x.size()) + " poses against " +
                                std::to_string(x0.size()));
  }
  Eigen::VectorXd dx(static_cast<Eigen::Index>(3 * x.size()));
  for (std::size_t k = 0; k < x.size(); ++k) {
    const auto at = static_cast<Eigen::Index>(3 * k);
    dx.segment<2>(at) = x[k].head<2>() - x0[k].head<2>();
    dx(at + 2) = normalizeAngle(x[k].z() - x0[k].z());
  }
  return dx;
}

}  // namespace rrr_graphslam::core
