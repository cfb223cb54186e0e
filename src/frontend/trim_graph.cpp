#include "rrr_graphslam/frontend/trim_graph.h"

#include <algorithm>
#include <map>

#include "rrr_graphslam/core/chow_liu.h"
#include "rrr_graphslam/core/gaussian_kl.h"
#include "rrr_graphslam/core/marginalization.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/core/union_find.h"
#include "rrr_graphslam/frontend/map_trimming.h"

namespace rrr_graphslam::frontend {
namespace {

using core::NodeId;
using Constraint = TrimGraph::Constraint;

bool touches(const core::PoseConstraint& c, const std::vector<char>& alive) {
  return alive[c.from] == 0 || alive[c.to] == 0;
}

}  // namespace

// The trusted graph over the nodes still alive, at their poses, in an optimizer (not yet optimized
// or factored), and the dense index of each node id (-1 for removed ones).
core::Optimizer TrimGraph::optimizer(std::vector<int>& index_of) const {
  core::PoseGraph graph;
  index_of.assign(alive_.size(), -1);
  int next = 0;
  for (std::size_t k = 0; k < alive_.size(); ++k) {
    if (!alive_[k]) continue;
    graph.addNode(static_cast<NodeId>(k), poses_[k]);
    index_of[k] = next++;
  }
  for (const Constraint& t : constraints_) {
    graph.addEdge(t.constraint.from, t.constraint.to, t.constraint.measurement,
                  t.constraint.information, core::EdgeKind::kOdometry);
  }
  for (const core::DenseFactor& f : dense_) graph.addDenseFactor(f);
  return core::makeOptimizer(graph);
}

// The measurement behind TrimRecord's KL figures: the trusted graph's covariance over the
// blanket (one factorization of the whole graph at the current poses), against which the tree
// and deletion are compared with the exact marginal.
void TrimGraph::measureKl(const core::Marginal& marginal,
                          const std::vector<core::DenseFactor>& replacement,
                          const TrimParams& params, TrimRecord& record) const {
  const core::Clock::time_point watch = core::Clock::now();
  std::vector<int> index_of;
  core::Optimizer trusted = optimizer(index_of);
  if (trusted.factorAtCurrentPoses() && trusted.covarianceAvailable()) {
    std::vector<int> blanket;
    for (NodeId b : marginal.blanket) blanket.push_back(index_of[b]);
    const core::KlReference exact(trusted.covariance(blanket));
    record.kl_clt_nats = exact.replacementKl(
        marginal,
        core::replacementModel(marginal, core::MarginalReplacement::kChowLiuTree, params.chow_liu));
    record.kl_delete_nats = exact.replacementKl(
        marginal, core::replacementModel(marginal, core::MarginalReplacement::kDelete));
    switch (params.sparsification) {
      case Sparsification::kClt:
        record.kl_nats = record.kl_clt_nats;
        break;
      case Sparsification::kDense:  // the factors made, linearized: zero up to rounding
        record.kl_nats = exact.replacementKl(
            marginal, core::linearizeConstraints({}, replacement, marginal.blanket,
                                                 marginal.linearization_point));
        break;
      case Sparsification::kDelete:
        record.kl_nats = record.kl_delete_nats;
        break;
    }
  }
  record.kl_seconds = core::secondsSince(watch);
}

TrimGraph::TrimGraph(const MapSnapshot& map)
    : dense_(map.dense_factors), alive_(map.nodes.size(), 1) {
  for (std::size_t e = 0; e < map.edges.size(); ++e) {
    const MapSnapshot::Edge& edge = map.edges[e];
    if (edge.kind == MapSnapshot::EdgeKind::kLoopCandidate &&
        edge.verdict != rrr::Verdict::kAccepted) {
      continue;
    }
    constraints_.push_back({{static_cast<NodeId>(edge.from), static_cast<NodeId>(edge.to),
                             edge.measurement, edge.information},
                            static_cast<int>(e),
                            -1});
  }
  poses_.reserve(map.nodes.size());
  for (const MapSnapshot::Node& node : map.nodes) poses_.push_back(node.map_pose);
}

void TrimGraph::optimize() {
  std::vector<int> index_of;
  core::Optimizer trusted = optimizer(index_of);
  trusted.optimize();
  for (std::size_t k = 0; k < alive_.size(); ++k) {
    if (index_of[k] >= 0) poses_[k] = trusted.poses()[static_cast<std::size_t>(index_of[k])];
  }
}

void TrimGraph::marginalize(const std::vector<NodeId>& group, const TrimParams& params,
                            TrimRecord& record) {
  const std::size_t n = size();
  std::vector<char> in_group(n, 0);
  // The trusted constraints touching the group: all the Schur complement needs. A part of the
  // group that shares none with the rest (a session nothing else saw) just leaves.
  for (NodeId k : group) in_group[k] = 1;
  std::vector<core::PoseConstraint> local;
  for (const Constraint& t : constraints_) {
    if (in_group[t.constraint.from] || in_group[t.constraint.to]) local.push_back(t.constraint);
  }
  std::vector<core::DenseFactor> local_dense;
  for (const core::DenseFactor& f : dense_) {
    if (std::any_of(f.nodes.begin(), f.nodes.end(), [&](auto id) { return in_group[id]; })) {
      local_dense.push_back(f);
    }
  }
  core::UnionFind pieces(n);
  std::vector<char> reaches_out(n, 0);
  for (const core::PoseConstraint& c : local) {
    const auto a = static_cast<std::size_t>(c.from);
    const auto b = static_cast<std::size_t>(c.to);
    if (in_group[a] && in_group[b]) pieces.unite(a, b);
  }
  for (const core::DenseFactor& f : local_dense) {  // its group nodes join one another
    std::size_t first_in = n;
    for (auto id : f.nodes) {
      if (!in_group[id]) continue;
      if (first_in == n) first_in = id;
      pieces.unite(first_in, id);
    }
  }
  for (const core::PoseConstraint& c : local) {
    const auto a = static_cast<std::size_t>(c.from);
    const auto b = static_cast<std::size_t>(c.to);
    if (in_group[a] != in_group[b]) reaches_out[pieces.find(in_group[a] ? a : b)] = 1;
  }
  for (const core::DenseFactor& f : local_dense) {
    const bool out =
        std::any_of(f.nodes.begin(), f.nodes.end(), [&](auto id) { return !in_group[id]; });
    for (auto id : f.nodes) {
      if (out && in_group[id]) reaches_out[pieces.find(id)] = 1;
    }
  }
  std::vector<NodeId> marginalized;
  for (NodeId k : group) {
    if (reaches_out[pieces.find(k)]) marginalized.push_back(k);
  }

  // The Schur complement over the blanket, and what replaces it.
  std::vector<Constraint> replacement;
  std::vector<core::DenseFactor> dense_replacement;
  if (!marginalized.empty()) {
    std::map<NodeId, core::Pose2> pose_of;
    for (const core::PoseConstraint& c : local) {
      pose_of.emplace(c.from, poses_[c.from]);
      pose_of.emplace(c.to, poses_[c.to]);
    }
    for (const core::DenseFactor& f : local_dense) {
      for (auto id : f.nodes) pose_of.emplace(id, poses_[id]);
    }
    const core::Marginal marginal =
        core::marginalizeNodes(local, local_dense, pose_of, marginalized);
    record.blanket_nodes = static_cast<int>(marginal.blanket.size());
    switch (params.sparsification) {
      case Sparsification::kClt:
        for (const core::ChowLiuEdge& e : core::chowLiuTree(marginal, params.chow_liu)) {
          replacement.push_back({e.constraint, -1, record.submap});
        }
        break;
      case Sparsification::kDense:
        dense_replacement = core::denseFactors(marginal);
        break;
      case Sparsification::kDelete:
        break;
    }
    if (params.report_kl) {
      measureKl(marginal, dense_replacement, params, record);
    }
  }

  // The group leaves with every constraint and dense factor it touched (those folded into the
  // marginal: their nodes reach out), and the replacement takes their place.
  for (NodeId k : group) alive_[k] = 0;
  std::vector<Constraint> still;
  still.reserve(constraints_.size() + replacement.size());
  for (Constraint& t : constraints_) {
    if (touches(t.constraint, alive_)) {
      ++record.removed_constraints;
    } else {
      still.push_back(std::move(t));
    }
  }
  record.marginal_edges = static_cast<int>(replacement.size());
  still.insert(still.end(), replacement.begin(), replacement.end());
  constraints_.swap(still);
  std::vector<core::DenseFactor> dense_still;
  for (core::DenseFactor& f : dense_) {
    if (std::any_of(f.nodes.begin(), f.nodes.end(), [&](auto id) { return alive_[id] == 0; })) {
      ++record.removed_constraints;
    } else {
      dense_still.push_back(std::move(f));
    }
  }
  record.dense_factors = static_cast<int>(dense_replacement.size());
  for (core::DenseFactor& f : dense_replacement) dense_still.push_back(std::move(f));
  dense_.swap(dense_still);
}

}  // namespace rrr_graphslam::frontend
