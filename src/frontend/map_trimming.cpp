#include "rrr_graphslam/frontend/map_trimming.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <exception>
#include <map>
#include <stdexcept>
#include <unordered_set>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/core/chow_liu.h"
#include "rrr_graphslam/core/gaussian_kl.h"
#include "rrr_graphslam/core/marginalization.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/core/union_find.h"
#include "rrr_graphslam/frontend/trim_memory.h"

namespace rrr_graphslam::frontend {

std::string toString(Sparsification sparsification) { return core::choiceName(sparsification); }

Sparsification parseSparsification(const std::string& text) {
  return core::parseChoiceOrThrow<Sparsification>(text, "sparsification");
}

std::string toString(TrimRule rule) { return core::choiceName(rule); }

TrimRule parseTrimRule(const std::string& text) {
  return core::parseChoiceOrThrow<TrimRule>(text, "trim_rule");
}

void validate(const TrimParams& params) {
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(params.trim_overlap_ratio > 0.0 && params.trim_overlap_ratio <= 1.0)) {
    fail("trim_overlap_ratio = " + std::to_string(params.trim_overlap_ratio) +
         " is out of range: must be in (0, 1]");
  }
  if (!(params.trim_min_fresh_area_m2 >= 0.0 && std::isfinite(params.trim_min_fresh_area_m2))) {
    fail("trim_min_fresh_area_m2 = " + std::to_string(params.trim_min_fresh_area_m2) +
         " is out of range: must be at least 0 m2");
  }
  if (params.keep_recent_submaps < 1) {
    fail("keep_recent_submaps = " + std::to_string(params.keep_recent_submaps) +
         " is out of range: must be at least 1");
  }
  if (!(params.coverage_resolution_m > 0.0 && params.coverage_resolution_m <= 10.0)) {
    fail("coverage_resolution_m = " + std::to_string(params.coverage_resolution_m) +
         " is out of range: must be in (0, 10] m");
  }
  if (!(params.memory_resolution_m > 0.0 && params.memory_resolution_m <= 10.0)) {
    fail("memory_resolution_m = " + std::to_string(params.memory_resolution_m) +
         " is out of range: must be in (0, 10] m");
  }
  validate(params.memory_evidence);
  if (params.threads < 1) fail("threads must be at least 1");
  if (params.revisit_gap_nodes < 0) {
    fail("revisit_gap_nodes = " + std::to_string(params.revisit_gap_nodes) +
         " is out of range: must be at least 0");
  }
}

bool OverlapRatioTrimming::trim(const SubmapCoverage& coverage) const {
  return coverage.observed_cells > 0 && static_cast<double>(coverage.covered_cells) >=
                                            ratio_ * static_cast<double>(coverage.observed_cells);
}

std::string OverlapRatioTrimming::describe() const {
  return "overlap ratio >= " + std::to_string(ratio_);
}

bool FreshAreaTrimming::trim(const SubmapCoverage& coverage) const {
  const double fresh =
      static_cast<double>(coverage.observed_cells - coverage.covered_cells) * coverage.cell_area_m2;
  return coverage.observed_cells > 0 && fresh < min_area_;
}

std::string FreshAreaTrimming::describe() const {
  return "fresh area < " + std::to_string(min_area_) + " m2";
}

std::unique_ptr<TrimmingStrategy> trimmingStrategy(const TrimParams& params) {
  switch (params.trim_rule) {
    case TrimRule::kFreshArea:
      return std::make_unique<FreshAreaTrimming>(params.trim_min_fresh_area_m2);
    case TrimRule::kOverlapRatio:
      break;
  }
  return std::make_unique<OverlapRatioTrimming>(params.trim_overlap_ratio);
}

int TrimReport::removedNodes() const {
  int n = 0;
  for (const TrimRecord& t : trims) n += t.removed_nodes;
  return n;
}

int TrimReport::marginalEdges() const {
  int n = 0;
  for (const TrimRecord& t : trims) n += t.marginal_edges;
  return n;
}

namespace {

using core::NodeId;
using Cells = std::vector<std::uint64_t>;  // sorted cell keys in the map frame

std::uint64_t cellKey(double x, double y, double resolution) {
  const auto ix = static_cast<std::int32_t>(std::floor(x / resolution));
  const auto iy = static_cast<std::int32_t>(std::floor(y / resolution));
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32) |
         static_cast<std::uint32_t>(iy);
}

// Step 1's grids: the cells each submap's scans observe at their map poses. The grids' lattice
// is aligned with the keys' (MRPT grows a grid by whole cells).
std::vector<Cells> observedCells(const MapSnapshot& map, const SubmapParams& submap_params,
                                 double resolution, int threads) {
  const int submaps = static_cast<int>(map.submaps.size());
  std::vector<Cells> cells(map.submaps.size());
  std::vector<std::exception_ptr> failed(map.submaps.size());
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (submaps > 1)
  for (int i = 0; i < submaps; ++i) {
    try {
      const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(i)];
      const core::Pose2& anchor = map.nodes[static_cast<std::size_t>(span.first_node)].map_pose;
      const auto lattice = [&](double v) {
        return static_cast<float>(std::floor(v / resolution) * resolution);
      };
      mrpt::maps::COccupancyGridMap2D grid(lattice(anchor.x() - 10.0), lattice(anchor.x() + 10.0),
                                           lattice(anchor.y() - 10.0), lattice(anchor.y() + 10.0),
                                           static_cast<float>(resolution));
      configureInsertion(grid, submap_params);
      for (int k = span.first_node; k <= span.last_node; ++k) {
        const MapSnapshot::Node& node = map.nodes[static_cast<std::size_t>(k)];
        const core::Pose2& p = node.map_pose;
        grid.insertObservation(*node.scan, mrpt::poses::CPose3D(p.x(), p.y(), 0.0, p.z(), 0, 0));
      }
      Cells& out = cells[static_cast<std::size_t>(i)];
      for (unsigned cy = 0; cy < grid.getSizeY(); ++cy) {
        for (unsigned cx = 0; cx < grid.getSizeX(); ++cx) {
          if (std::abs(grid.getCell(cx, cy) - 0.5F) < 1e-3F) continue;  // never observed
          out.push_back(cellKey(grid.idx2x(cx), grid.idx2y(cy), resolution));
        }
      }
      std::sort(out.begin(), out.end());
      out.erase(std::unique(out.begin(), out.end()), out.end());
    } catch (...) {
      failed[static_cast<std::size_t>(i)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  return cells;
}

// A trusted constraint of the working graph: an edge of the map (`origin`), or a marginal
// constraint a trim made (origin -1, `submap` the trimmed submap).
struct Trusted {
  core::PoseConstraint constraint;
  int origin = -1;
  int submap = -1;
};

bool touches(const core::PoseConstraint& c, const std::vector<char>& removed) {
  return removed[c.from] != 0 || removed[c.to] != 0;
}

// The trusted graph over the nodes still alive, at `poses`, in an optimizer (not yet optimized
// or factored), and the dense index of each node id (-1 for removed ones).
core::Optimizer trustedOptimizer(const std::vector<Trusted>& trusted,
                                 const std::vector<core::DenseFactor>& dense,
                                 const std::vector<char>& alive,
                                 const std::vector<core::Pose2>& poses,
                                 std::vector<int>& index_of) {
  core::PoseGraph graph;
  index_of.assign(alive.size(), -1);
  int next = 0;
  for (std::size_t k = 0; k < alive.size(); ++k) {
    if (!alive[k]) continue;
    graph.addNode(static_cast<NodeId>(k), poses[k]);
    index_of[k] = next++;
  }
  for (const Trusted& t : trusted) {
    graph.addEdge(t.constraint.from, t.constraint.to, t.constraint.measurement,
                  t.constraint.information, core::EdgeKind::kOdometry);
  }
  for (const core::DenseFactor& f : dense) graph.addDenseFactor(f);
  return core::makeOptimizer(graph);
}

// The trusted graph at its minimum: `poses` of the nodes still alive move there.
void optimizeTrusted(const std::vector<Trusted>& trusted,
                     const std::vector<core::DenseFactor>& dense, const std::vector<char>& alive,
                     std::vector<core::Pose2>& poses) {
  std::vector<int> index_of;
  core::Optimizer optimizer = trustedOptimizer(trusted, dense, alive, poses, index_of);
  optimizer.optimize();
  for (std::size_t k = 0; k < alive.size(); ++k) {
    if (index_of[k] >= 0) poses[k] = optimizer.poses()[static_cast<std::size_t>(index_of[k])];
  }
}

// The measurement behind TrimRecord's KL figures: the trusted graph's covariance over the
// blanket (one factorization of the whole graph at the current poses), against which the tree
// and deletion are compared with the exact marginal.
void measureKl(const std::vector<Trusted>& trusted, const std::vector<core::DenseFactor>& dense,
               const std::vector<char>& alive, const std::vector<core::Pose2>& poses,
               const core::Marginal& marginal, const std::vector<core::DenseFactor>& replacement,
               const TrimParams& params, TrimRecord& record) {
  const core::Clock::time_point watch = core::Clock::now();
  std::vector<int> index_of;
  core::Optimizer optimizer = trustedOptimizer(trusted, dense, alive, poses, index_of);
  if (optimizer.factorAtCurrentPoses() && optimizer.covarianceAvailable()) {
    std::vector<int> blanket;
    for (NodeId b : marginal.blanket) blanket.push_back(index_of[b]);
    const core::KlReference exact(optimizer.covariance(blanket));
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

}  // namespace

TrimResult trimMap(const MapSnapshot& map, const TrimParams& params,
                   const SubmapParams& submap_params, NewestSession newest) {
  return trimMap(map, params, *trimmingStrategy(params), submap_params, newest);
}

TrimResult trimMap(const MapSnapshot& map, const TrimParams& params,
                   const TrimmingStrategy& strategy, const SubmapParams& submap_params,
                   NewestSession newest) {
  validate(params);
  map.check();
  const core::Clock::time_point total = core::Clock::now();
  TrimResult result;
  TrimReport& report = result.report;
  const std::size_t n = map.nodes.size();
  const int submaps = static_cast<int>(map.submaps.size());

  // Nodes a pending loop touches: their submaps wait; in a running session, so do those its loops
  // in open clusters touch (their verdicts are not final).
  const int newest_session = n > 0 ? map.nodes.back().session : 0;
  const bool running = newest == NewestSession::kRunning;
  auto inNewest = [&](int node) {
    return map.nodes[static_cast<std::size_t>(node)].session == newest_session;
  };
  std::vector<char> pending_node(n, 0);
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind != MapSnapshot::EdgeKind::kLoopCandidate) continue;
    if (e.verdict == rrr::Verdict::kPending || (running && e.cluster < 0)) {
      pending_node[static_cast<std::size_t>(e.from)] =
          pending_node[static_cast<std::size_t>(e.to)] = 1;
    }
  }

  // 1. Coverage, from the newest submap back, against the newer kept ones.
  const core::Clock::time_point coverage_watch = core::Clock::now();
  const std::vector<Cells> cells =
      observedCells(map, submap_params, params.coverage_resolution_m, params.threads);
  std::vector<char> trimmed(map.submaps.size(), 0);
  std::unordered_set<std::uint64_t> kept_cells;
  // In a running session, the kept submaps of its own that do not cover its older ones yet: they
  // begin less than revisit_gap_nodes after those end (newest first).
  std::deque<int> not_yet;
  auto covers = [&](int t, const MapSnapshot::Submap& span) {
    const MapSnapshot::Submap& newer = map.submaps[static_cast<std::size_t>(t)];
    return !running || !inNewest(span.first_node) || params.revisit_gap_nodes <= 0 ||
           newer.first_node - span.last_node >= params.revisit_gap_nodes;
  };
  for (int s = submaps - 1; s >= 0; --s) {
    const Cells& own = cells[static_cast<std::size_t>(s)];
    const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(s)];
    while (!not_yet.empty() && covers(not_yet.front(), span)) {
      const Cells& newer = cells[static_cast<std::size_t>(not_yet.front())];
      kept_cells.insert(newer.begin(), newer.end());
      not_yet.pop_front();
    }
    SubmapCoverage c;
    c.submap = s;
    c.observed_cells = own.size();
    c.cell_area_m2 = params.coverage_resolution_m * params.coverage_resolution_m;
    for (std::uint64_t key : own) c.covered_cells += kept_cells.count(key);
    report.coverage.push_back(c);
    const bool current = params.keep_current_session && inNewest(span.first_node);
    bool trim = s < submaps - params.keep_recent_submaps && !current && strategy.trim(c);
    if (trim) {
      for (int k = span.first_node; k <= span.last_node && trim; ++k) {
        if (pending_node[static_cast<std::size_t>(k)]) trim = false;
      }
      if (!trim) ++report.waiting_submaps;
    }
    trimmed[static_cast<std::size_t>(s)] = trim ? 1 : 0;
    if (!trim) not_yet.push_back(s);
  }
  report.coverage_seconds = core::secondsSince(coverage_watch);

  // 2. Owned nodes: those every submap holding them is trimmed from; each goes with the first.
  std::vector<int> owner(n, -1);
  std::vector<char> kept_by_some(n, 0);
  for (int s = 0; s < submaps; ++s) {
    const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(s)];
    for (int k = span.first_node; k <= span.last_node; ++k) {
      const auto node = static_cast<std::size_t>(k);
      if (!trimmed[static_cast<std::size_t>(s)]) {
        kept_by_some[node] = 1;
      } else if (owner[node] < 0) {
        owner[node] = s;
      }
    }
  }
  // The trusted graph: odometry, accepted loops, marginal constraints.
  std::vector<Trusted> trusted;
  for (std::size_t e = 0; e < map.edges.size(); ++e) {
    const MapSnapshot::Edge& edge = map.edges[e];
    if (edge.kind == MapSnapshot::EdgeKind::kLoopCandidate &&
        edge.verdict != rrr::Verdict::kAccepted) {
      continue;
    }
    trusted.push_back({{static_cast<NodeId>(edge.from), static_cast<NodeId>(edge.to),
                        edge.measurement, edge.information},
                       static_cast<int>(e),
                       -1});
  }
  // The map's dense factors (node ids are node indices), trusted too.
  std::vector<core::DenseFactor> dense = map.dense_factors;
  std::vector<core::Pose2> poses(n);
  for (std::size_t k = 0; k < n; ++k) poses[k] = map.nodes[k].map_pose;
  std::vector<char> alive(n, 1);
  std::vector<char> removed(n, 0);

  // The nodes that leave, in groups that trusted constraints join: each group is marginalized at
  // once (neighbouring trimmed submaps together), so no tree is ever approximated again.
  std::vector<char> leaves(n, 0);
  for (std::size_t k = 0; k < n; ++k) leaves[k] = owner[k] >= 0 && !kept_by_some[k];
  core::UnionFind joined(n);
  if (params.group_neighbours) {
    for (const Trusted& t : trusted) {
      const auto a = static_cast<std::size_t>(t.constraint.from);
      const auto b = static_cast<std::size_t>(t.constraint.to);
      if (leaves[a] && leaves[b]) joined.unite(a, b);
    }
    for (const core::DenseFactor& f : dense) {
      for (auto a : f.nodes) {
        for (auto b : f.nodes) {
          if (leaves[a] && leaves[b]) joined.unite(a, b);
        }
      }
    }
  } else {
    std::vector<std::size_t> first_of_owner(map.submaps.size(), n);
    for (std::size_t k = 0; k < n; ++k) {
      if (!leaves[k]) continue;
      std::size_t& first = first_of_owner[static_cast<std::size_t>(owner[k])];
      if (first == n) first = k;
      joined.unite(first, k);
    }
  }
  std::vector<std::vector<NodeId>> groups;
  std::vector<int> group_of_root(n, -1);
  for (std::size_t k = 0; k < n; ++k) {
    if (!leaves[k]) continue;
    int& g = group_of_root[joined.find(k)];
    if (g < 0) {
      g = static_cast<int>(groups.size());
      groups.emplace_back();
    }
    groups[static_cast<std::size_t>(g)].push_back(static_cast<NodeId>(k));
  }

  // 3-4. Each group, oldest first, linearized at the trusted graph's minimum (one optimization
  // for every trim: marginalizing exactly leaves the other nodes' minimum where it was, and the
  // tree keeps the marginal's gradient, so later trims find the graph still there; deletion
  // moves it, and with report_kl the graph is optimized again after each deletion).
  const core::Clock::time_point optimize_watch = core::Clock::now();
  if (!groups.empty()) optimizeTrusted(trusted, dense, alive, poses);
  report.optimize_seconds = core::secondsSince(optimize_watch);

  // 5. Memory, at the same estimate (trim_memory.h).
  const core::Clock::time_point memory_watch = core::Clock::now();
  std::vector<char> stays(n, 0);
  for (std::size_t k = 0; k < n; ++k) stays[k] = !leaves[k];
  TrimmedMemory memory = memoryAfterTrim(map, poses, stays, params, submap_params,
                                         params.remember_trimmed_cells && !groups.empty());
  report.remembered_patches = memory.made_patches;
  report.memory_seconds = core::secondsSince(memory_watch);
  std::vector<char> in_group(n, 0);
  for (const std::vector<NodeId>& group : groups) {
    const core::Clock::time_point watch = core::Clock::now();
    TrimRecord record;
    std::vector<int> owners;
    for (NodeId k : group) owners.push_back(owner[k]);
    std::sort(owners.begin(), owners.end());
    owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
    record.submap = owners.front();
    record.submaps = static_cast<int>(owners.size());
    record.removed_nodes = static_cast<int>(group.size());
    const int s = record.submap;
    // The trusted constraints touching the group: all the Schur complement needs. A part of the
    // group that shares none with the rest (a session nothing else saw) just leaves.
    for (NodeId k : group) in_group[k] = 1;
    std::vector<core::PoseConstraint> local;
    for (const Trusted& t : trusted) {
      if (in_group[t.constraint.from] || in_group[t.constraint.to]) local.push_back(t.constraint);
    }
    core::UnionFind pieces(n);
    std::vector<char> reaches_out(n, 0);
    for (const core::PoseConstraint& c : local) {
      const auto a = static_cast<std::size_t>(c.from);
      const auto b = static_cast<std::size_t>(c.to);
      if (in_group[a] && in_group[b]) pieces.unite(a, b);
    }
    std::vector<core::DenseFactor> local_dense;
    for (const core::DenseFactor& f : dense) {
      if (std::any_of(f.nodes.begin(), f.nodes.end(), [&](auto id) { return in_group[id]; })) {
        local_dense.push_back(f);
      }
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
    std::vector<Trusted> replacement;
    std::vector<core::DenseFactor> dense_replacement;
    if (!marginalized.empty()) {
      std::map<NodeId, core::Pose2> pose_of;
      for (const core::PoseConstraint& c : local) {
        pose_of.emplace(c.from, poses[c.from]);
        pose_of.emplace(c.to, poses[c.to]);
      }
      for (const core::DenseFactor& f : local_dense) {
        for (auto id : f.nodes) pose_of.emplace(id, poses[id]);
      }
      const core::Marginal marginal =
          core::marginalizeNodes(local, local_dense, pose_of, marginalized);
      record.blanket_nodes = static_cast<int>(marginal.blanket.size());
      switch (params.sparsification) {
        case Sparsification::kClt:
          for (const core::ChowLiuEdge& e : core::chowLiuTree(marginal, params.chow_liu)) {
            replacement.push_back({e.constraint, -1, s});
          }
          break;
        case Sparsification::kDense:
          dense_replacement = core::denseFactors(marginal);
          break;
        case Sparsification::kDelete:
          break;
      }
      if (params.report_kl) {
        measureKl(trusted, dense, alive, poses, marginal, dense_replacement, params, record);
      }
    }
    for (NodeId k : group) {
      in_group[k] = 0;
      alive[k] = 0;
      removed[k] = 1;
    }
    std::vector<Trusted> still;
    still.reserve(trusted.size() + replacement.size());
    for (Trusted& t : trusted) {
      if (touches(t.constraint, removed)) {
        ++record.removed_constraints;
      } else {
        still.push_back(std::move(t));
      }
    }
    record.marginal_edges = static_cast<int>(replacement.size());
    still.insert(still.end(), replacement.begin(), replacement.end());
    trusted.swap(still);
    // Dense factors holding a removed node were folded into the marginal (their nodes reach out).
    std::vector<core::DenseFactor> dense_still;
    for (core::DenseFactor& f : dense) {
      if (std::any_of(f.nodes.begin(), f.nodes.end(), [&](auto id) { return removed[id] != 0; })) {
        ++record.removed_constraints;
      } else {
        dense_still.push_back(std::move(f));
      }
    }
    record.dense_factors = static_cast<int>(dense_replacement.size());
    for (core::DenseFactor& f : dense_replacement) dense_still.push_back(std::move(f));
    dense.swap(dense_still);
    record.seconds = core::secondsSince(watch) - record.kl_seconds;
    report.trims.push_back(record);
    if (params.report_kl && params.sparsification == Sparsification::kDelete &&
        record.removed_constraints > 0) {
      // Deletion drops the removed constraints' pull on the blanket: the minimum moves, and the
      // next trim's KL is measured at the new one (the trims themselves need no linearization).
      const core::Clock::time_point again = core::Clock::now();
      optimizeTrusted(trusted, dense, alive, poses);
      report.optimize_seconds += core::secondsSince(again);
    }
  }
  if (!groups.empty()) {
    const core::Clock::time_point watch = core::Clock::now();
    optimizeTrusted(trusted, dense, alive, poses);  // the trimmed map at its own minimum
    report.optimize_seconds += core::secondsSince(watch);
  }

  // The trimmed map, renumbered.
  MapSnapshot& out = result.map;
  out.format_version = kMapFormatVersion;
  out.params = map.params;
  std::vector<int>& new_index = result.node_index;
  new_index.assign(n, -1);
  std::vector<int> new_session(map.sessions.size(), -1);
  for (std::size_t k = 0; k < n; ++k) {
    if (!alive[k]) continue;
    const MapSnapshot::Node& node = map.nodes[k];
    const auto session = static_cast<std::size_t>(node.session);
    if (new_session[session] < 0) {
      new_session[session] = static_cast<int>(out.sessions.size());
      MapSnapshot::Session kept = map.sessions[session];
      kept.first_node = static_cast<int>(out.nodes.size());
      out.sessions.push_back(kept);
    }
    new_index[k] = static_cast<int>(out.nodes.size());
    MapSnapshot::Node moved = node;
    moved.session = new_session[session];
    moved.map_pose = poses[k];
    out.nodes.push_back(std::move(moved));
  }
  std::vector<char> trusted_kept(map.edges.size(), 0);
  for (const Trusted& t : trusted) {
    if (t.origin >= 0) trusted_kept[static_cast<std::size_t>(t.origin)] = 1;
  }
  for (std::size_t e = 0; e < map.edges.size(); ++e) {
    const MapSnapshot::Edge& edge = map.edges[e];
    const bool is_trusted = edge.kind != MapSnapshot::EdgeKind::kLoopCandidate ||
                            edge.verdict == rrr::Verdict::kAccepted;
    const bool ends_alive = alive[static_cast<std::size_t>(edge.from)] != 0 &&
                            alive[static_cast<std::size_t>(edge.to)] != 0;
    if (is_trusted ? !trusted_kept[e] : !ends_alive) {
      if (!is_trusted) ++report.dropped_rejected_loops;  // pending ones wait: never here
      continue;
    }
    MapSnapshot::Edge moved = edge;
    moved.from = new_index[static_cast<std::size_t>(edge.from)];
    moved.to = new_index[static_cast<std::size_t>(edge.to)];
    out.edges.push_back(std::move(moved));
  }
  for (const Trusted& t : trusted) {
    if (t.origin >= 0) continue;
    ++report.marginal_edges_kept;
    MapSnapshot::Edge edge;
    edge.from = new_index[static_cast<std::size_t>(t.constraint.from)];
    edge.to = new_index[static_cast<std::size_t>(t.constraint.to)];
    edge.kind = MapSnapshot::EdgeKind::kMarginal;
    edge.measurement = t.constraint.measurement;
    edge.information = t.constraint.information;
    edge.verdict = rrr::Verdict::kAccepted;
    edge.reason = "Chow-Liu tree of trimmed submap " + std::to_string(t.submap);
    out.edges.push_back(std::move(edge));
  }
  for (core::DenseFactor f : dense) {
    for (auto& id : f.nodes) id = static_cast<mrpt::graphs::TNodeID>(new_index[id]);
    out.dense_factors.push_back(std::move(f));
  }
  report.dense_factors_kept = static_cast<int>(out.dense_factors.size());
  result.submap_index.assign(map.submaps.size(), -1);
  for (int s = 0; s < submaps; ++s) {
    if (trimmed[static_cast<std::size_t>(s)]) continue;
    result.submap_index[static_cast<std::size_t>(s)] = static_cast<int>(out.submaps.size());
    const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(s)];
    out.submaps.push_back({new_index[static_cast<std::size_t>(span.first_node)],
                           new_index[static_cast<std::size_t>(span.last_node)]});
  }
  out.lifelong = map.lifelong;
  const core::Clock::time_point forget_watch = core::Clock::now();
  report.forgotten_cells = settleMemory(memory, new_index, out, params);
  out.memory = std::move(memory.patches);
  report.memory_seconds += core::secondsSince(forget_watch);
  report.remembered_cells = rememberedCells(out.memory);
  report.trimmed_submaps = submaps - static_cast<int>(out.submaps.size());
  out.lifelong.trimmed_submaps += report.trimmed_submaps;
  out.lifelong.marginalized_nodes += static_cast<int>(n - out.nodes.size());
  out.check();
  report.seconds = core::secondsSince(total);
  return result;
}

}  // namespace rrr_graphslam::frontend
