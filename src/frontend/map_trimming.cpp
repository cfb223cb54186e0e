#include "rrr_graphslam/frontend/map_trimming.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <exception>
#include <stdexcept>
#include <unordered_set>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/core/union_find.h"
#include "rrr_graphslam/frontend/trim_graph.h"
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

// Nodes a pending loop touches: their submaps wait; in a running session, so do those its loops
// in open clusters touch (their verdicts are not final).
std::vector<char> pendingNodes(const MapSnapshot& map, bool running) {
  std::vector<char> pending(map.nodes.size(), 0);
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind != MapSnapshot::EdgeKind::kLoopCandidate) continue;
    if (e.verdict == rrr::Verdict::kPending || (running && e.cluster < 0)) {
      pending[static_cast<std::size_t>(e.from)] = pending[static_cast<std::size_t>(e.to)] = 1;
    }
  }
  return pending;
}

// 1. Coverage, from the newest submap back, against the newer kept ones: which submaps go.
std::vector<char> trimmedSubmaps(const MapSnapshot& map, const TrimParams& params,
                                 const TrimmingStrategy& strategy,
                                 const SubmapParams& submap_params, bool running,
                                 TrimReport& report) {
  const int submaps = static_cast<int>(map.submaps.size());
  const int newest_session = map.nodes.empty() ? 0 : map.nodes.back().session;
  auto inNewest = [&](int node) {
    return map.nodes[static_cast<std::size_t>(node)].session == newest_session;
  };
  const std::vector<char> pending = pendingNodes(map, running);
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
        if (pending[static_cast<std::size_t>(k)]) trim = false;
      }
      if (!trim) ++report.waiting_submaps;
    }
    trimmed[static_cast<std::size_t>(s)] = trim ? 1 : 0;
    if (!trim) not_yet.push_back(s);
  }
  return trimmed;
}

// The nodes that leave and the groups they leave in.
struct Leaving {
  std::vector<int> owner;    // per node, the first trimmed submap holding it (-1: none)
  std::vector<char> leaves;  // per node
  std::vector<std::vector<NodeId>> groups;
};

// 2. Owned nodes: those every submap holding them is trimmed from; each goes with the first.
// They leave in groups that trusted constraints join: each group is marginalized at once
// (neighbouring trimmed submaps together), so no tree is ever approximated again.
Leaving leavingNodes(const MapSnapshot& map, const std::vector<char>& trimmed,
                     const TrimGraph& graph, const TrimParams& params) {
  const std::size_t n = map.nodes.size();
  const int submaps = static_cast<int>(map.submaps.size());
  Leaving leaving;
  std::vector<int>& owner = leaving.owner;
  owner.assign(n, -1);
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
  std::vector<char>& leaves = leaving.leaves;
  leaves.assign(n, 0);
  for (std::size_t k = 0; k < n; ++k) leaves[k] = owner[k] >= 0 && !kept_by_some[k];
  core::UnionFind joined(n);
  if (params.group_neighbours) {
    for (const TrimGraph::Constraint& t : graph.constraints()) {
      const auto a = static_cast<std::size_t>(t.constraint.from);
      const auto b = static_cast<std::size_t>(t.constraint.to);
      if (leaves[a] && leaves[b]) joined.unite(a, b);
    }
    for (const core::DenseFactor& f : graph.denseFactors()) {
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
  std::vector<std::vector<NodeId>>& groups = leaving.groups;
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
  return leaving;
}

// The trimmed map: the nodes that stay, renumbered, at the graph's poses; the edges that stay;
// the trims' marginal constraints and dense factors; the kept submaps; the memory settled.
void writeTrimmed(const MapSnapshot& map, const TrimGraph& graph, const std::vector<char>& trimmed,
                  TrimmedMemory memory, const TrimParams& params, TrimResult& result) {
  const std::size_t n = map.nodes.size();
  const int submaps = static_cast<int>(map.submaps.size());
  TrimReport& report = result.report;
  MapSnapshot& out = result.map;
  out.format_version = kMapFormatVersion;
  out.params = map.params;
  std::vector<int>& new_index = result.node_index;
  new_index.assign(n, -1);
  std::vector<int> new_session(map.sessions.size(), -1);
  for (std::size_t k = 0; k < n; ++k) {
    if (!graph.alive(k)) continue;
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
    moved.map_pose = graph.poses()[k];
    out.nodes.push_back(std::move(moved));
  }
  std::vector<char> trusted_kept(map.edges.size(), 0);
  for (const TrimGraph::Constraint& t : graph.constraints()) {
    if (t.origin >= 0) trusted_kept[static_cast<std::size_t>(t.origin)] = 1;
  }
  for (std::size_t e = 0; e < map.edges.size(); ++e) {
    const MapSnapshot::Edge& edge = map.edges[e];
    const bool is_trusted = edge.kind != MapSnapshot::EdgeKind::kLoopCandidate ||
                            edge.verdict == rrr::Verdict::kAccepted;
    const bool ends_alive = graph.alive(static_cast<std::size_t>(edge.from)) &&
                            graph.alive(static_cast<std::size_t>(edge.to));
    if (is_trusted ? !trusted_kept[e] : !ends_alive) {
      if (!is_trusted) ++report.dropped_rejected_loops;  // pending ones wait: never here
      continue;
    }
    MapSnapshot::Edge moved = edge;
    moved.from = new_index[static_cast<std::size_t>(edge.from)];
    moved.to = new_index[static_cast<std::size_t>(edge.to)];
    out.edges.push_back(std::move(moved));
  }
  for (const TrimGraph::Constraint& t : graph.constraints()) {
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
  for (core::DenseFactor f : graph.denseFactors()) {
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

  const core::Clock::time_point coverage_watch = core::Clock::now();
  const std::vector<char> trimmed = trimmedSubmaps(map, params, strategy, submap_params,
                                                   newest == NewestSession::kRunning, report);
  report.coverage_seconds = core::secondsSince(coverage_watch);

  // The trusted graph: odometry, accepted loops, marginal constraints, dense factors.
  TrimGraph graph(map);
  const Leaving leaving = leavingNodes(map, trimmed, graph, params);
  const std::vector<std::vector<NodeId>>& groups = leaving.groups;

  // 3-4. Each group, oldest first, linearized at the trusted graph's minimum (one optimization
  // for every trim: marginalizing exactly leaves the other nodes' minimum where it was, and the
  // tree keeps the marginal's gradient, so later trims find the graph still there; deletion
  // moves it, and with report_kl the graph is optimized again after each deletion).
  const core::Clock::time_point optimize_watch = core::Clock::now();
  if (!groups.empty()) graph.optimize();
  report.optimize_seconds = core::secondsSince(optimize_watch);

  // 5. Memory, at the same estimate (trim_memory.h).
  const core::Clock::time_point memory_watch = core::Clock::now();
  std::vector<char> stays(n, 0);
  for (std::size_t k = 0; k < n; ++k) stays[k] = !leaving.leaves[k];
  TrimmedMemory memory = memoryAfterTrim(map, graph.poses(), stays, params, submap_params,
                                         params.remember_trimmed_cells && !groups.empty());
  report.remembered_patches = memory.made_patches;
  report.memory_seconds = core::secondsSince(memory_watch);
  for (const std::vector<NodeId>& group : groups) {
    const core::Clock::time_point watch = core::Clock::now();
    TrimRecord record;
    std::vector<int> owners;
    for (NodeId k : group) owners.push_back(leaving.owner[k]);
    std::sort(owners.begin(), owners.end());
    owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
    record.submap = owners.front();
    record.submaps = static_cast<int>(owners.size());
    record.removed_nodes = static_cast<int>(group.size());
    graph.marginalize(group, params, record);
    record.seconds = core::secondsSince(watch) - record.kl_seconds;
    report.trims.push_back(record);
    if (params.report_kl && params.sparsification == Sparsification::kDelete &&
        record.removed_constraints > 0) {
      // Deletion drops the removed constraints' pull on the blanket: the minimum moves, and the
      // next trim's KL is measured at the new one (the trims themselves need no linearization).
      const core::Clock::time_point again = core::Clock::now();
      graph.optimize();
      report.optimize_seconds += core::secondsSince(again);
    }
  }
  if (!groups.empty()) {
    const core::Clock::time_point watch = core::Clock::now();
    graph.optimize();  // the trimmed map at its own minimum
    report.optimize_seconds += core::secondsSince(watch);
  }

  writeTrimmed(map, graph, trimmed, std::move(memory), params, result);
  report.seconds = core::secondsSince(total);
  return result;
}

}  // namespace rrr_graphslam::frontend
