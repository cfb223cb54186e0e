#include "rrr_graphslam/rrr/verification_graph.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::rrr {
namespace {

std::vector<OdometryChain::Link> odometryLinks(
    const core::PoseGraph& graph,
    const std::unordered_map<core::PoseGraph::NodeId, int>& index_of) {
  std::vector<OdometryChain::Link> links;
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const auto& e = graph.edge(k);
    if (e.kind != core::EdgeKind::kOdometry) continue;
    const int from = index_of.at(e.from);
    const int to = index_of.at(e.to);
    if (std::abs(from - to) != 1) {
      throw std::invalid_argument("odometry edge " + std::to_string(k) + " (" +
                                  std::to_string(e.from) + " -> " + std::to_string(e.to) +
                                  ") does not join consecutive nodes; mark it as a loop candidate");
    }
    links.push_back({from, to, graph.measurement(k), graph.information(k)});
  }
  return links;
}

std::unordered_map<core::PoseGraph::NodeId, int> indexIds(
    const std::vector<core::PoseGraph::NodeId>& ids) {
  std::unordered_map<core::PoseGraph::NodeId, int> index_of;
  for (std::size_t i = 0; i < ids.size(); ++i) index_of.emplace(ids[i], static_cast<int>(i));
  return index_of;
}

}  // namespace

VerificationGraph::VerificationGraph(const core::PoseGraph& graph,
                                     const core::OptimizerParams& params)
    : node_ids_(graph.nodeIds()),
      optimizer_(core::makeOptimizer(graph, params)),
      chain_(static_cast<int>(node_ids_.size()), odometryLinks(graph, indexIds(node_ids_))) {
  initial_poses_ = optimizer_.poses();
  const auto index_of = indexIds(node_ids_);
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const auto& e = graph.edge(k);
    const int c = static_cast<int>(k);  // makeOptimizer: constraint k is edge k
    if (e.kind == core::EdgeKind::kMarginal) {
      marginal_.push_back({index_of.at(e.from), index_of.at(e.to), c});
    }
    if (e.kind != core::EdgeKind::kLoopCandidate) continue;
    optimizer_.setActive(c, false);
    candidates_.push_back(LoopCandidate{k, index_of.at(e.from), index_of.at(e.to), c,
                                        graph.measurement(k), graph.information(k)});
  }
}

int VerificationGraph::addNode(core::PoseGraph::NodeId id, const core::Pose2& initial_pose) {
  node_ids_.push_back(id);
  initial_poses_.push_back(initial_pose);
  optimizer_.addNode(initial_pose);
  return chain_.appendNode();
}

void VerificationGraph::addOdometry(int from, int to, const core::Pose2& measurement,
                                    const Eigen::Matrix3d& information) {
  chain_.linkNewestNode({from, to, measurement, information});  // validates the pair first
  optimizer_.addConstraint(from, to, measurement, information, true);
}

int VerificationGraph::addMarginal(int from, int to, const core::Pose2& measurement,
                                   const Eigen::Matrix3d& information) {
  if (from < 0 || to < 0 || from >= numNodes() || to >= numNodes() || from == to) {
    throw std::invalid_argument("marginal constraint " + std::to_string(from) + " -> " +
                                std::to_string(to) + " needs two distinct existing nodes");
  }
  const int c = optimizer_.addConstraint(from, to, measurement, information, true);
  marginal_.push_back({from, to, c});
  return static_cast<int>(marginal_.size()) - 1;
}

int VerificationGraph::addDenseFactor(const std::vector<int>& nodes,
                                      const core::DenseFactor& factor) {
  return optimizer_.addDenseFactor(nodes, factor);  // checks the nodes and the factor
}

int VerificationGraph::numComponents(const std::vector<int>& component) {
  return component.empty() ? 0 : *std::max_element(component.begin(), component.end()) + 1;
}

std::vector<std::size_t> VerificationGraph::componentsJoinedBy(
    const std::vector<int>& candidates) const {
  const std::vector<int> component = trustedComponents();
  const auto of = [&](int node) {
    return static_cast<std::size_t>(component[static_cast<std::size_t>(node)]);
  };
  core::UnionFind joined(static_cast<std::size_t>(numComponents(component)));
  for (int k : candidates) joined.unite(of(candidate(k).from), of(candidate(k).to));
  std::vector<std::size_t> out(component.size());
  for (int n = 0; n < numNodes(); ++n) out[static_cast<std::size_t>(n)] = joined.find(of(n));
  return out;
}

std::vector<int> VerificationGraph::trustedComponents() const {
  core::UnionFind joined(static_cast<std::size_t>(chain_.numSessions()));
  for (const MarginalLink& m : marginal_) {
    joined.unite(static_cast<std::size_t>(chain_.session(m.from)),
                 static_cast<std::size_t>(chain_.session(m.to)));
  }
  for (int f = 0; f < optimizer_.numDenseFactors(); ++f) {
    const std::vector<int>& nodes = optimizer_.denseFactorNodes(f);
    for (int n : nodes) {
      joined.unite(static_cast<std::size_t>(chain_.session(nodes.front())),
                   static_cast<std::size_t>(chain_.session(n)));
    }
  }
  std::vector<int> number(static_cast<std::size_t>(chain_.numSessions()), -1);
  std::vector<int> component(static_cast<std::size_t>(numNodes()));
  int next = 0;
  for (int n = 0; n < numNodes(); ++n) {
    int& c = number[joined.find(static_cast<std::size_t>(chain_.session(n)))];
    if (c < 0) c = next++;
    component[static_cast<std::size_t>(n)] = c;
  }
  return component;
}

std::vector<int> VerificationGraph::trustedConstraints() const {
  std::vector<char> candidate(static_cast<std::size_t>(optimizer_.numConstraints()), 0);
  for (const LoopCandidate& c : candidates_) candidate[static_cast<std::size_t>(c.constraint)] = 1;
  std::vector<int> trusted;
  for (int c = 0; c < optimizer_.numConstraints(); ++c) {
    if (!candidate[static_cast<std::size_t>(c)]) trusted.push_back(c);
  }
  return trusted;
}

double VerificationGraph::trustedChi2At(const std::vector<core::Pose2>& poses) const {
  double sum = 0.0;
  for (int c : trustedConstraints()) {
    const Eigen::Vector3d e = core::edgeError(
        poses.at(static_cast<std::size_t>(optimizer_.from(c))),
        poses.at(static_cast<std::size_t>(optimizer_.to(c))), optimizer_.measurement(c));
    sum += e.dot(optimizer_.information(c) * e);
  }
  std::vector<core::Pose2> at;
  for (int f = 0; f < optimizer_.numDenseFactors(); ++f) {
    at.clear();
    for (int n : optimizer_.denseFactorNodes(f))
      at.push_back(poses.at(static_cast<std::size_t>(n)));
    sum += core::denseFactorChi2(optimizer_.denseFactor(f), at);
  }
  return sum;
}

double VerificationGraph::trustedChi2() const {
  if (numMarginalTerms() == 0) return 0.0;  // odometry alone is a forest: it holds exactly
  if (trusted_chi2_marginals_ == numMarginalTerms()) return trusted_chi2_;
  core::Optimizer trusted(optimizer_.params());
  for (const core::Pose2& p : initial_poses_) trusted.addNode(p);
  for (int c : trustedConstraints()) {
    trusted.addConstraint(optimizer_.from(c), optimizer_.to(c), optimizer_.measurement(c),
                          optimizer_.information(c));
  }
  for (int f = 0; f < optimizer_.numDenseFactors(); ++f) {
    trusted.addDenseFactor(optimizer_.denseFactorNodes(f), optimizer_.denseFactor(f));
  }
  trusted_chi2_ = trusted.optimize().final_chi2;
  trusted_chi2_marginals_ = numMarginalTerms();
  return trusted_chi2_;
}

int VerificationGraph::addCandidate(int from, int to, const core::Pose2& measurement,
                                    const Eigen::Matrix3d& information, std::size_t edge) {
  if (from < 0 || to < 0 || from >= numNodes() || to >= numNodes() || from == to) {
    throw std::invalid_argument("loop candidate " + std::to_string(from) + " -> " +
                                std::to_string(to) + " needs two distinct existing nodes");
  }
  const int c = optimizer_.addConstraint(from, to, measurement, information, false);
  candidates_.push_back(LoopCandidate{edge, from, to, c, measurement, information});
  return numCandidates() - 1;
}

core::PoseGraph VerificationGraph::poseGraphWith(const std::vector<int>& candidates) const {
  core::PoseGraph graph;
  for (int k = 0; k < numNodes(); ++k) {
    graph.addNode(node_ids_[static_cast<std::size_t>(k)],
                  initial_poses_[static_cast<std::size_t>(k)]);
  }
  std::vector<bool> marginal(static_cast<std::size_t>(optimizer_.numConstraints()), false);
  for (const MarginalLink& m : marginal_) marginal[static_cast<std::size_t>(m.constraint)] = true;
  auto add = [&](int c, core::EdgeKind kind) {
    graph.addEdge(node_ids_[static_cast<std::size_t>(optimizer_.from(c))],
                  node_ids_[static_cast<std::size_t>(optimizer_.to(c))], optimizer_.measurement(c),
                  optimizer_.information(c), kind);
  };
  for (int c : trustedConstraints()) {
    add(c, marginal[static_cast<std::size_t>(c)] ? core::EdgeKind::kMarginal
                                                 : core::EdgeKind::kOdometry);
  }
  for (int f = 0; f < optimizer_.numDenseFactors(); ++f) {
    core::DenseFactor factor = optimizer_.denseFactor(f);
    const std::vector<int>& nodes = optimizer_.denseFactorNodes(f);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      factor.nodes[i] = node_ids_[static_cast<std::size_t>(nodes[i])];
    }
    graph.addDenseFactor(std::move(factor));
  }
  for (int k : candidates) add(candidate(k).constraint, core::EdgeKind::kLoopCandidate);
  return graph;
}

void VerificationGraph::extendByOdometry(std::vector<core::Pose2>& poses) const {
  while (poses.size() < static_cast<std::size_t>(numNodes())) {
    const int k = static_cast<int>(poses.size());
    poses.push_back(k > 0 && chain_.sameSession(k - 1, k)
                        ? core::compose(poses.back(), chain_.relativePose(k - 1, k))
                        : initial_poses_[static_cast<std::size_t>(k)]);
  }
}

std::vector<int> VerificationGraph::touchedNodes(const std::vector<int>& candidates) const {
  std::vector<int> nodes;
  nodes.reserve(2 * candidates.size());
  for (int k : candidates) {
    nodes.push_back(candidate(k).from);
    nodes.push_back(candidate(k).to);
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

void VerificationGraph::activateOnly(const std::vector<int>& candidates) {
  for (const LoopCandidate& c : candidates_) optimizer_.setActive(c.constraint, false);
  for (int k : candidates) optimizer_.setActive(candidate(k).constraint, true);
}

core::OptimizationResult VerificationGraph::optimize(const std::vector<int>& candidates,
                                                     const core::OptimizationRequest& request) {
  activateOnly(candidates);
  return optimizer_.optimize(request);
}

}  // namespace rrr_graphslam::rrr
