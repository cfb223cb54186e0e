#pragma once
// What rrr_slam_offline prints after a run besides its summary: the sessions of the map and the
// moment the current one was tied, the per-scan latency, and what a lifelong trim did (the
// `trim_*` key-value lines and one `trim_record` per marginalization, which bench_lifelong reads).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "rrr_graphslam/core/quantile.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/frontend/online_trimmer.h"

namespace rrr_graphslam::tools {

using core::nearestRank;

// The trim's summary line, one 'key value' line per figure, then a 'trim_record' line per
// marginalization (bench_lifelong reads them).
inline void printTrimReport(const frontend::TrimReport& report,
                            const frontend::TrimParams& params) {
  std::vector<double> ms;
  double kl = 0.0, kl_clt = 0.0, kl_delete = 0.0, worst_ratio = 0.0, kl_seconds = 0.0;
  for (const frontend::TrimRecord& t : report.trims) {
    ms.push_back(1e3 * t.seconds);
    kl_seconds += t.kl_seconds;
    kl += t.kl_nats;
    kl_clt += t.kl_clt_nats;
    kl_delete += t.kl_delete_nats;
    if (t.kl_delete_nats > 0.0) {
      worst_ratio = std::max(worst_ratio, t.kl_clt_nats / t.kl_delete_nats);
    }
  }
  // Without TrimParams::report_kl the divergences were not measured: nan, not 0.
  auto measured = [&](double kl_nats) { return params.report_kl ? kl_nats : std::nan(""); };
  kl = measured(kl);
  kl_clt = measured(kl_clt);
  kl_delete = measured(kl_delete);
  worst_ratio = measured(worst_ratio);
  std::sort(ms.begin(), ms.end());
  auto quantile = [&](double q) { return ms.empty() ? 0.0 : nearestRank(ms, q); };
  std::printf(
      "lifelong       trimmed %d submaps (%s, %s): %d nodes marginalized into %d marginal "
      "edges in %.2f s; %d submaps wait for pending loops\n",
      report.trimmed_submaps, frontend::trimmingStrategy(params)->describe().c_str(),
      frontend::toString(params.sparsification).c_str(), report.removedNodes(),
      report.marginalEdges(), report.seconds, report.waiting_submaps);
  std::printf(
      "trim_submaps %d\ntrim_nodes %d\ntrim_marginal_edges %d\n"
      "trim_marginal_edges_kept %d\ntrim_dense_factors_kept %d\ntrim_dropped_rejected_loops "
      "%d\ntrim_seconds "
      "%.4f\ntrim_coverage_seconds %.4f\n"
      "trim_p50_ms %.2f\ntrim_p99_ms %.2f\ntrim_kl %.6g\ntrim_kl_clt %.6g\n"
      "trim_kl_delete %.6g\ntrim_kl_ratio_max %.6g\ntrim_optimize_seconds %.4f\n"
      "trim_kl_seconds %.4f\n",
      report.trimmed_submaps, report.removedNodes(), report.marginalEdges(),
      report.marginal_edges_kept, report.dense_factors_kept, report.dropped_rejected_loops,
      report.seconds, report.coverage_seconds, quantile(0.5), quantile(0.99), kl, kl_clt, kl_delete,
      worst_ratio, report.optimize_seconds, kl_seconds);
  std::printf(
      "trim_remembered_patches %d\ntrim_remembered_cells %zu\ntrim_forgotten_cells %zu\n"
      "trim_memory_seconds %.4f\n",
      report.remembered_patches, report.remembered_cells, report.forgotten_cells,
      report.memory_seconds);
  for (const frontend::TrimRecord& t : report.trims) {
    std::printf(
        "trim_record submap %d submaps %d nodes %d blanket %d constraints %d edges %d "
        "kl %.6g kl_clt %.6g kl_delete %.6g ms %.3f kl_ms %.3f dense_factors %d\n",
        t.submap, t.submaps, t.removed_nodes, t.blanket_nodes, t.removed_constraints,
        t.marginal_edges, measured(t.kl_nats), measured(t.kl_clt_nats), measured(t.kl_delete_nats),
        1e3 * t.seconds, 1e3 * t.kl_seconds, t.dense_factors);
  }
}

// One 'online_trim' line (rrr_slam_offline --trim-every-n-nodes).
inline void printOnlineTrim(const frontend::OnlineTrimRecord& r) {
  std::printf(
      "online_trim scan %zu nodes %d -> %d submaps_trimmed %d marginal_edges %d waiting %d "
      "checkpoint_ms %.2f trim_ms %.2f replayed %d replay_ms %.2f\n",
      r.scan, r.nodes_before, r.nodes_after, r.report.trimmed_submaps, r.report.marginalEdges(),
      r.report.waiting_submaps, r.checkpoint_ms, r.trim_ms, r.replayed_scans, r.replay_ms);
}

// The online trims' summary line.
inline void printOnlineTrims(const std::vector<frontend::OnlineTrimRecord>& records,
                             int every_n_nodes, bool continued_a_map) {
  std::vector<double> trim_ms, checkpoint_ms;
  int submaps = 0, nodes = 0;
  for (const frontend::OnlineTrimRecord& r : records) {
    trim_ms.push_back(r.trim_ms);
    checkpoint_ms.push_back(r.checkpoint_ms);
    submaps += r.report.trimmed_submaps;
    nodes += r.report.removedNodes();
  }
  std::sort(trim_ms.begin(), trim_ms.end());
  std::sort(checkpoint_ms.begin(), checkpoint_ms.end());
  auto q = [](const std::vector<double>& v, double p) {
    return v.empty() ? 0.0 : nearestRank(v, p);
  };
  std::printf(
      "online trims   %zu (every %d nodes%s): %d submaps trimmed, %d nodes "
      "marginalized; trim %.1f ms p50, %.1f max (off the mapping thread in the nodelet); "
      "checkpoint %.1f ms p50, %.1f max\n",
      records.size(), every_n_nodes, continued_a_map ? " once tied" : "", submaps, nodes,
      q(trim_ms, 0.5), q(trim_ms, 1.0), q(checkpoint_ms, 0.5), q(checkpoint_ms, 1.0));
}

// Nodes and edges per session, and when the current session was tied to the earlier ones.
inline void printSessions(const frontend::LaserSlam& slam) {
  const auto& sessions = slam.sessions();
  if (sessions.size() < 2) return;
  const core::PoseGraph graph = slam.rrr().toPoseGraph();
  const int nodes = slam.rrr().numNodes();
  auto sessionOf = [&](int node) {
    int s = 0;
    while (s + 1 < static_cast<int>(sessions.size()) &&
           sessions[static_cast<std::size_t>(s) + 1].first_node <= node) {
      ++s;
    }
    return s;
  };
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    const int first = sessions[s].first_node;
    const int end = s + 1 < sessions.size() ? sessions[s + 1].first_node : nodes;
    int edges = 0, crossing_accepted = 0;
    for (std::size_t e = 0; e < graph.numEdges(); ++e) {
      const auto& edge = graph.edge(e);
      const int a = sessionOf(static_cast<int>(edge.from)),
                b = sessionOf(static_cast<int>(edge.to));
      if (a != static_cast<int>(s) && b != static_cast<int>(s)) continue;
      ++edges;
    }
    for (int k = 0; k < slam.rrr().numCandidates(); ++k) {
      const auto& c = slam.rrr().candidate(k);
      const int a = sessionOf(c.from), b = sessionOf(c.to);
      if (a != b && (a == static_cast<int>(s) || b == static_cast<int>(s)) &&
          slam.rrr().verdict(k) == rrr::Verdict::kAccepted) {
        ++crossing_accepted;
      }
    }
    std::printf("session %-6zu %s: %d nodes, %d edges, %d accepted loops to other sessions\n", s,
                sessions[s].name.c_str(), end - first, edges, crossing_accepted);
  }
  const auto& current = sessions.back();
  if (const auto& tie = slam.tie()) {
    std::printf("relocalized    at node %d (the session's node %d, %.1f s after its start)%s\n",
                tie->node, tie->session_node, tie->timestamp - current.start_time,
                slam.tied() ? "" : "; not tied at the end");
  } else if (slam.tied()) {
    std::printf("relocalized    only by the final decision\n");
  } else {
    std::printf("relocalized    no\n");
  }
  if (!slam.tied() && sessions.size() > 1) {
    const double spread = slam.acceptedCrossingSpread();
    if (spread < 0.0) {
      std::printf(
          "               no loop to the map is accepted: this session is a separate "
          "component of the map\n");
    } else {
      std::printf(
          "               the loops to the map RRR accepts lie within %.1f m of each "
          "other along the session (relocalization_confirm_distance %g m): placed by "
          "them, not confirmed\n",
          spread, slam.params().loops.relocalization_confirm_distance_m);
    }
  }
}

// What each scan cost the robot: the time from its arrival to its pose (local SLAM, the loop
// search of a new node and RRR's decisions it triggered).
inline void printLatency(std::vector<double> seconds) {
  if (seconds.empty()) return;
  std::sort(seconds.begin(), seconds.end());
  auto at = [&](double q) { return 1e3 * nearestRank(seconds, q); };
  std::printf("latency        per scan p50 %.2f ms, p99 %.2f ms, max %.2f ms (%zu scans)\n",
              at(0.5), at(0.99), 1e3 * seconds.back(), seconds.size());
}

}  // namespace rrr_graphslam::tools
