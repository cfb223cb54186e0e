#include "rrr_graphslam/core/pose_graph.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::core {
namespace {

// CPose2D(x, y, phi) wraps phi as wrapTo2Pi(phi + pi) - pi, which rounds even an angle already
// in range (0.1 is kept as 0.10000000000000009), maps +pi to -pi, and sends the double just below
// -pi to +pi (phi + pi is -4.4e-16; adding 2 pi rounds to 2 pi): a pose read back from a written
// file would differ from the one written. The angle is wrapped here exactly (std::remainder, into
// (-pi, pi]) and set without MRPT's wrap.
mrpt::poses::CPose2D toMrpt(const Pose2& pose) {
  mrpt::poses::CPose2D out;
  out.x(pose.x());
  out.y(pose.y());
  out.phi(normalizeAngle(pose.z()));
  return out;
}

}  // namespace

PoseGraph::PoseGraph(const PoseGraph& other) { copyFrom(other); }

PoseGraph& PoseGraph::operator=(const PoseGraph& other) {
  if (this != &other) copyFrom(other);
  return *this;
}

void PoseGraph::copyFrom(const PoseGraph& other) {
  network_ = other.network_;
  // The copied multimap keeps the element order, so walking both in step maps each edge of
  // `other` to its copy; edges_ must then point into our own storage.
  std::unordered_map<const void*, Network::edges_map_t::iterator> copy_of;
  copy_of.reserve(other.network_.edges.size());
  auto mine = network_.edges.begin();
  for (auto theirs = other.network_.edges.begin(); theirs != other.network_.edges.end();
       ++theirs, ++mine) {
    copy_of.emplace(&*theirs, mine);
  }
  edges_ = other.edges_;
  for (Edge& e : edges_) e.storage = copy_of.at(&*e.storage);
  dense_factors_ = other.dense_factors_;
}

EdgeKind PoseGraph::defaultKind(NodeId from, NodeId to) {
  const NodeId gap = from > to ? from - to : to - from;
  return gap == 1 ? EdgeKind::kOdometry : EdgeKind::kLoopCandidate;
}

void PoseGraph::addNode(NodeId id, const Pose2& pose) {
  if (hasNode(id)) throw std::invalid_argument("duplicate node id " + std::to_string(id));
  network_.nodes[id] = toMrpt(pose);
}

Pose2 PoseGraph::pose(NodeId id) const {
  const auto it = network_.nodes.find(id);
  if (it == network_.nodes.end()) throw std::out_of_range("unknown node id " + std::to_string(id));
  return {it->second.x(), it->second.y(), it->second.phi()};
}

void PoseGraph::setPose(NodeId id, const Pose2& pose) {
  const auto it = network_.nodes.find(id);
  if (it == network_.nodes.end()) throw std::out_of_range("unknown node id " + std::to_string(id));
  it->second = toMrpt(pose);
}

std::size_t PoseGraph::addEdge(NodeId from, NodeId to, const Pose2& measurement,
                               const Eigen::Matrix3d& information, EdgeKind kind) {
  if (!hasNode(from)) throw std::invalid_argument("edge from unknown node " + std::to_string(from));
  if (!hasNode(to)) throw std::invalid_argument("edge to unknown node " + std::to_string(to));
  if (from == to) throw std::invalid_argument("self-loop on node " + std::to_string(from));

  mrpt::math::CMatrixDouble33 info;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) info(r, c) = information(r, c);
  }
  Network::edge_t edge(toMrpt(measurement), info);
  // std::multimap inserts equal keys at the upper bound, so duplicates keep their order.
  const auto it = network_.edges.emplace(std::make_pair(from, to), edge);
  edges_.push_back(Edge{from, to, kind, it});
  return edges_.size() - 1;
}

std::size_t PoseGraph::addDenseFactor(DenseFactor factor) {
  const std::string problem = denseFactorProblem(factor);
  if (!problem.empty()) throw std::invalid_argument("dense factor: " + problem);
  for (NodeId id : factor.nodes) {
    if (!hasNode(id))
      throw std::invalid_argument("dense factor on unknown node " + std::to_string(id));
  }
  dense_factors_.push_back(std::move(factor));
  return dense_factors_.size() - 1;
}

Pose2 PoseGraph::measurement(std::size_t index) const {
  const auto& mean = edges_.at(index).storage->second.mean;
  return {mean.x(), mean.y(), mean.phi()};
}

Eigen::Matrix3d PoseGraph::information(std::size_t index) const {
  const auto& info = edges_.at(index).storage->second.cov_inv;
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = info(r, c);
  }
  return out;
}

std::vector<PoseGraph::NodeId> PoseGraph::nodeIds() const {
  std::vector<NodeId> ids;
  ids.reserve(network_.nodes.size());
  for (const auto& [id, pose] : network_.nodes) ids.push_back(id);
  return ids;  // std::map iterates in increasing id order
}

std::vector<std::vector<PoseGraph::NodeId>> PoseGraph::connectedComponents() const {
  const std::vector<NodeId> ids = nodeIds();
  std::unordered_map<NodeId, std::size_t> index_of;
  index_of.reserve(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) index_of.emplace(ids[i], i);

  UnionFind sets(ids.size());
  for (const Edge& e : edges_) sets.unite(index_of.at(e.from), index_of.at(e.to));
  for (const DenseFactor& f : dense_factors_) {
    for (NodeId id : f.nodes) sets.unite(index_of.at(f.nodes.front()), index_of.at(id));
  }

  std::unordered_map<std::size_t, std::size_t> component_of_root;
  std::vector<std::vector<NodeId>> components;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto [it, inserted] = component_of_root.emplace(sets.find(i), components.size());
    if (inserted) components.emplace_back();
    components[it->second].push_back(ids[i]);
  }
  return components;  // ids were visited in increasing order, so each component is sorted
}

}  // namespace rrr_graphslam::core
