// rrr_slam_offline LOG.clf[.gz] --output graph.g2o --decisions decisions.tsv --trajectory traj.txt
//                  --map map [...]
// 2D laser SLAM on a CARMEN log: local SLAM into submaps, branch-and-bound loop search, RRR on the
// candidates; writes the graph, the decisions, every scan's optimized pose (TUM format, ipc
// timestamps) and the map (map_server PGM + YAML, and a PNG with the loops).

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "decision_stream.h"
#include "false_loops.h"
#include "params_cli.h"
#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/blas_kernel.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/core/text_file.h"
#include "rrr_graphslam/frontend/carmen_log.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/map_io.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/frontend/online_trimmer.h"
#include "rrr_graphslam/frontend/trajectory_refinement.h"
#include "rrr_graphslam/rrr/decisions_io.h"
#include "rrr_params_cli.h"
#include "slam_offline_arguments.h"
#include "slam_offline_report.h"
#include "tum_trajectory.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;
namespace rrr = rrr_graphslam::rrr;

using tools::slam_offline::Arguments;
using tools::slam_offline::parseArguments;

// Poses from index `first` on, TUM format.
void writeTrajectory(const std::string& path, const std::vector<double>& stamps,
                     const std::vector<core::Pose2>& poses, std::size_t first) {
  tools::writeTumTrajectory(path, "rrr_slam_offline", stamps, poses, first);
}

// `id timestamp session` per node of the run's graph (--output's ids; the session's index in the
// map, as rrr_map_info numbers them).
void writeNodeStamps(const std::string& path, const frontend::LaserSlam& slam) {
  const std::vector<rrr::OnlineRrr::NodeId>& ids = slam.rrr().nodeIds();
  const std::vector<double>& stamps = slam.nodeTimestamps();
  if (ids.size() != stamps.size()) {
    throw std::logic_error("--node-stamps: " + std::to_string(ids.size()) + " nodes but " +
                           std::to_string(stamps.size()) + " node timestamps");
  }
  const std::vector<int> sessions = slam.nodeSessions();
  core::writeFileAtomically(path, [&](std::ostream& out) {
    out << "# node_id ipc_timestamp session (rrr_slam_offline; ids as in --output)\n"
        << std::fixed << std::setprecision(6);
    for (std::size_t k = 0; k < ids.size(); ++k) {
      out << ids[k] << ' ' << stamps[k] << ' ' << sessions[k] << '\n';
    }
  });
}

// The optimized pose of every scan in the map (nodes of loaded sessions one each); this run's
// placed scans (`placed`: their indices in the log) are refined against the final map (see
// trajectory_refinement.h) unless refinement is off.
std::vector<core::Pose2> refinedTrajectory(const frontend::LaserSlam& slam,
                                           const frontend::CarmenLog& log,
                                           const std::vector<std::size_t>& placed,
                                           const frontend::TrajectoryRefinementParams& params) {
  std::vector<core::Pose2> poses = slam.scanMapPoses();
  if (params.resolution_m <= 0.0 || placed.empty()) return poses;
  const auto map = frontend::MatchGrid::fromOccupancyGrid(slam.renderMap(params.resolution_m),
                                                          slam.params().local.submap.unknown_value);
  std::vector<frontend::PointCloud> points;
  points.reserve(placed.size());
  for (std::size_t k : placed) {
    points.push_back(frontend::matchingPoints(frontend::RangeScan::fromCarmen(log.scans[k]),
                                              slam.params().local.scan));
  }
  const auto first = static_cast<std::ptrdiff_t>(slam.sessionFirstScan());
  const std::vector<core::Pose2> session(poses.begin() + first, poses.end());
  const std::vector<core::Pose2> refined = frontend::refineTrajectory(map, points, session, params);
  std::copy(refined.begin(), refined.end(), poses.begin() + first);
  return poses;
}

std::vector<frontend::LoopLine> loopLines(const frontend::LaserSlam& slam) {
  const auto poses = slam.rrr().mapPoses();
  std::vector<frontend::LoopLine> lines;
  for (int k = 0; k < slam.rrr().numCandidates(); ++k) {
    const auto& c = slam.rrr().candidate(k);
    lines.push_back({poses[static_cast<std::size_t>(c.from)], poses[static_cast<std::size_t>(c.to)],
                     slam.rrr().verdict(k) == rrr::Verdict::kAccepted});
  }
  return lines;
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parseArguments(argc, argv);
  if (const auto warning = core::blasKernelWarning())
    std::fprintf(stderr, "warning: %s\n", warning->c_str());
  try {
    const auto start = std::chrono::steady_clock::now();
    const frontend::CarmenLog log = frontend::readCarmenLog(args.log);
    std::unique_ptr<frontend::LaserSlam> slam_owner;
    if (args.load_map.empty()) {
      slam_owner = std::make_unique<frontend::LaserSlam>(args.params, args.session_name);
    } else {
      const auto load_start = std::chrono::steady_clock::now();
      const frontend::MapSnapshot map = frontend::readMapFile(args.load_map);
      try {
        slam_owner = frontend::LaserSlam::fromMap(map, args.params, args.session_name,
                                                  args.localization_only
                                                      ? frontend::SessionMode::kLocalization
                                                      : frontend::SessionMode::kMapping);
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error(args.load_map + ": " + e.what());
      }
      if (args.initial_pose) slam_owner->setInitialPose(*args.initial_pose);
      std::printf("loaded map     %s: %zu sessions, %zu nodes, %zu submaps in %.2f s\n",
                  args.load_map.c_str(), map.sessions.size(), map.nodes.size(), map.submaps.size(),
                  core::secondsSince(load_start));
      // The parameters this run takes that differ from the map's (those that could not differ
      // were refused by fromMap).
      for (const auto& [name, now] : slam_owner->snapshotParams()) {
        for (const auto& [saved_name, saved] : map.params) {
          if (saved_name == name && saved != now) {
            std::printf("parameter      %s is %s here, %s in the map\n", name.c_str(), now.c_str(),
                        saved.c_str());
          }
        }
      }
    }
    frontend::OnlineTrimmer online({args.trim, args.trim_every_n_nodes, true});
    std::vector<frontend::OnlineTrimRecord> online_trims;
    const bool progress = !args.quiet && isatty(STDERR_FILENO);
    const std::size_t n =
        args.max_scans > 0 ? std::min(args.max_scans, log.scans.size()) : log.scans.size();
    std::vector<std::size_t> placed;  // log indices of the scans the front end placed
    placed.reserve(n);
    std::vector<double> latency;  // seconds of each addScan call
    latency.reserve(n);
    constexpr int kRefusalsShown = 10;
    tools::DecisionStream stream;
    tools::FalseLoopInjector false_loops(args.false_loops);
    for (std::size_t k = 0; k < n; ++k) {
      const auto& record = log.scans[k];
      const auto scan_start = std::chrono::steady_clock::now();
      frontend::LaserSlam& slam = *slam_owner;
      const frontend::RangeScan scan = frontend::RangeScan::fromCarmen(record);
      std::optional<int> node;
      try {
        node = slam.addScan(scan, record.odom_pose);
        false_loops.afterScan(slam);
        placed.push_back(k);
        latency.push_back(core::secondsSince(scan_start));
      } catch (const frontend::SensorMismatch& e) {
        throw std::runtime_error(args.log + ":" + std::to_string(record.line) + ": scan " +
                                 std::to_string(k + 1) + " cannot continue " + args.load_map +
                                 ": " + e.what());
      } catch (const frontend::ScanRefused& e) {
        if (slam.stats().refused_scans <= kRefusalsShown) {
          std::fprintf(
              stderr, "%s%s:%zu: scan %zu (ipc_timestamp %.6f) refused: %s%s\n",
              progress ? "\n" : "", args.log.c_str(), record.line, k + 1, record.timestamp,
              e.what(),
              slam.stats().refused_scans == kRefusalsShown ? " (further ones counted)" : "");
        }
      }
      if (!args.decision_stream.empty()) {
        stream.record(slam.rrr(), k + 1, slam.rrr().numNodes(), record.timestamp, false);
      } else {
        slam.rrr().takeChanges();  // nobody reads them: they would pile up for the whole run
      }
      if (progress && (k % 100 == 0 || k + 1 == n)) {
        const auto status = slam.rrr().status();
        std::fprintf(
            stderr, "\r[slam] scan %zu/%zu  nodes %d  submaps %d  candidates %d  accepted %d   ",
            k + 1, n, status.nodes, slam.stats().submaps, status.candidates, status.accepted);
      }
      // The last use of `slam`: a trim may replace it.
      if (auto trimmed = online.afterScan(slam, scan, record.odom_pose, node)) {
        slam_owner = std::move(trimmed);
      }
      if (online.finished() > static_cast<int>(online_trims.size())) {
        online_trims.push_back(*online.last());
        tools::printOnlineTrim(online_trims.back());
      }
    }
    if (progress) std::fprintf(stderr, "\n");
    frontend::LaserSlam& slam = *slam_owner;
    slam.finish();
    if (!args.decision_stream.empty()) {
      stream.record(slam.rrr(), n, slam.rrr().numNodes(), log.scans[n - 1].timestamp, true);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const auto& stats = slam.stats();
    const auto status = slam.rrr().status();
    const double duration = log.scans[n - 1].timestamp - log.scans.front().timestamp;

    std::printf("log            %s: %zu scans, %.1f s\n", args.log.c_str(), n, duration);
    if (stats.refused_scans > 0) {
      std::printf("refused        %d scans (not placed; not in --trajectory)\n",
                  stats.refused_scans);
    }
    if (stats.velocity_predicted_scans > 0) {
      std::printf(
          "odometry off   %d scans matched around the last step repeated, not the "
          "odometry's prediction (scan_velocity_prediction)\n",
          stats.velocity_predicted_scans);
    }
    std::printf("nodes          %d in %d submaps\n", stats.nodes, stats.submaps);
    std::printf("loop search    %lld node-submap pairs, %.2f ms each (%.2f s on %d threads)\n",
                stats.loop_searches,
                stats.loop_searches > 0 ? 1e3 * stats.loop_search_pair_seconds /
                                              static_cast<double>(stats.loop_searches)
                                        : 0.0,
                stats.loop_search_seconds, args.params.loops.threads);
    if (args.params.rrr.verifier.verifier != rrr::Verifier::kRrr) {
      std::printf("verifier       %s\n", rrr::toString(args.params.rrr.verifier.verifier).c_str());
    }
    std::printf("candidates     %d in %d clusters\n", status.candidates, status.clusters);
    if (args.false_loops.fraction > 0.0) {
      std::printf("false loops    %d injected among them (--false-loops %g, seed %u)\n",
                  false_loops.injected(), args.false_loops.fraction, args.false_loops.seed);
    }
    if (stats.contradicted_matches > 0) {
      std::printf(
          "contradicted   %d matches to the map not proposed (the session's path they place "
          "ends in the map's free space)\n",
          stats.contradicted_matches);
    }
    if (stats.ambiguous_matches > 0) {
      std::printf(
          "ambiguous      %d matches not proposed (a distinct pose of their search scored "
          "nearly as well)\n",
          stats.ambiguous_matches);
    }
    if (stats.rival_searches > 0) {
      std::printf("rival search   %lld of them around a second reading of where the session lies\n",
                  stats.rival_searches);
    }
    std::printf("accepted       %d\n", status.accepted);
    std::printf("rejected       %d\n", status.rejected);
    tools::printSessions(slam);
    tools::printLatency(latency);
    if (args.trim_every_n_nodes > 0) {
      tools::printOnlineTrims(online_trims, args.trim_every_n_nodes, !args.load_map.empty());
    }
    std::printf(
        "time           %.2f s (local SLAM %.2f, loop search %.2f, RRR %.2f), %.1fx real time\n",
        seconds, stats.local_slam_seconds, stats.loop_search_seconds, stats.rrr_seconds,
        seconds > 0 ? duration / seconds : 0.0);

    if (!args.output.empty()) {
      core::writePoseGraph(slam.rrr().mapPoseGraph(), args.output);
      std::printf("output         %s\n", args.output.c_str());
    }
    if (!args.node_stamps.empty()) {
      writeNodeStamps(args.node_stamps, slam);
      std::printf("node stamps    %s\n", args.node_stamps.c_str());
    }
    if (!args.decisions.empty()) {
      rrr::writeDecisions(args.decisions, slam.rrr().decisionRows());
      std::printf("decisions      %s\n", args.decisions.c_str());
    }
    if (!args.decision_stream.empty()) {
      stream.write(args.decision_stream);
      std::printf("decision stream %s (%zu rows)\n", args.decision_stream.c_str(), stream.size());
    }
    if (!args.trajectory.empty() || !args.session_trajectory.empty()) {
      const auto refine_start = std::chrono::steady_clock::now();
      const std::vector<core::Pose2> poses = refinedTrajectory(slam, log, placed, args.refinement);
      const std::string refined = args.refinement.resolution_m > 0.0
                                      ? " (refined against the final map in " +
                                            std::to_string(core::secondsSince(refine_start)) + " s)"
                                      : "";
      if (!args.trajectory.empty()) {
        writeTrajectory(args.trajectory, slam.scanTimestamps(), poses, 0);
        std::printf("trajectory     %s%s\n", args.trajectory.c_str(), refined.c_str());
      }
      if (!args.session_trajectory.empty()) {
        writeTrajectory(args.session_trajectory, slam.scanTimestamps(), poses,
                        slam.sessionFirstScan());
        std::printf("session traj.  %s%s\n", args.session_trajectory.c_str(), refined.c_str());
      }
    }
    if (!args.save_map.empty()) {
      frontend::MapSnapshot map = slam.snapshot();
      if (args.lifelong) {
        frontend::TrimResult trimmed = frontend::trimMap(map, args.trim, args.params.local.submap);
        tools::printTrimReport(trimmed.report, args.trim);
        map = std::move(trimmed.map);
      }
      const auto save_start = std::chrono::steady_clock::now();
      frontend::writeMapFile(map, args.save_map);
      std::printf("saved map      %s in %.2f s\n", args.save_map.c_str(),
                  core::secondsSince(save_start));
    }
    if (!args.map.empty()) {
      const auto grid = slam.renderMap(args.map_resolution, args.map_layering, args.map_render);
      frontend::writeMapServerFiles(grid, args.map);
      frontend::writeMapPng(grid, args.map + ".png", slam.rrr().mapPoses(), loopLines(slam));
      std::printf("map            %s.pgm, %s.yaml, %s.png\n", args.map.c_str(), args.map.c_str(),
                  args.map.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_slam_offline: " << e.what() << "\n";
    return 1;
  }
}
