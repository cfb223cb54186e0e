// rrr_slam_offline LOG.clf[.gz] --output graph.g2o --decisions decisions.tsv --trajectory traj.txt
//                  --map map [...]
// 2D laser SLAM on a CARMEN log: local SLAM into submaps, branch-and-bound loop search, RRR on the
// candidates; writes the graph, the decisions, every scan's optimized pose (TUM format, ipc
// timestamps) and the map (map_server PGM + YAML, and a PNG with the loops).

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <iomanip>
#include <iostream>
#include <string>

#include "command_line.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/text_file.h"
#include "rrr_graphslam/frontend/carmen_log.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_io.h"
#include "rrr_graphslam/frontend/trajectory_refinement.h"
#include "rrr_graphslam/rrr/decisions_io.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;
namespace rrr = rrr_graphslam::rrr;

const char* const kUsage =
    "usage: rrr_slam_offline LOG.clf[.gz] [--output GRAPH.g2o] [--decisions DECISIONS.tsv]\n"
    "                        [--trajectory TRAJ.txt] [--map MAP] [--map-resolution M]\n"
    "                        [--scans-per-submap N] [--min-score S] [--max-constraint-distance M]\n"
    "                        [--linear-window M] [--angular-window DEG] [--depth D]\n"
    "                        [--min-node-separation N] [--search-every N] [--max-range M]\n"
    "                        [--loop-max-range M] [--submap-resolution M] [--voxel M]\n"
    "                        [--odometry-stddev M] [--pause-after-match N] [--threads N]\n"
    "                        [--min-travel M] [--min-rotation DEG] [--correlative-window M]\n"
    "                        [--correlative-translation-cost W] [--correlative-rotation-cost W]\n"
    "                        [--local-refinement least-squares|icp]\n"
    "                        [--translation-weight W] [--rotation-weight W]\n"
    "                        [--search-min-points N] [--search-voxel M] [--search-grid-factor F]\n"
    "                        [--refine-resolution M] [--alpha A] [--max-scans N]\n"
    "                        [--quiet]\n"
    "  LOG               CARMEN log (FLASER or ROBOTLASER1 lines; the scans carry the odometry)\n"
    "  --output          the pose graph: nodes at their optimized poses, odometry and every loop\n"
    "                    candidate (rrr_offline can decide it again)\n"
    "  --decisions       TSV 'from to cluster verdict reason', one row per loop candidate\n"
    "  --trajectory      optimized pose of every scan, TUM format 't x y z qx qy qz qw' with the\n"
    "                    log's ipc_timestamp\n"
    "  --map             writes MAP.pgm + MAP.yaml (map_server) and MAP.png (accepted loops\n"
    "                    green, rejected red)\n"
    "  --map-resolution  m per cell of the written map (default 0.05)\n"
    "  --scans-per-submap, --min-score, --max-constraint-distance, --linear-window,\n"
    "  --angular-window, --depth, --min-node-separation, --search-every, --max-range,\n"
    "  --loop-max-range, --submap-resolution, --voxel (matching points' voxel size):\n"
    "                    front-end settings (see README)\n"
    "  --odometry-stddev M  std of one local-SLAM step between nodes: M m, M/2 rad\n"
    "  --search-every N  a submap is searched by at most every N-th node (default 2)\n"
    "  --pause-after-match N  nodes a submap rests after a match (default 10)\n"
    "  --threads N       threads of the loop search (default 2)\n"
    "  --min-travel M, --min-rotation DEG  motion filter: a scan becomes a node after this\n"
    "                    travel or rotation (default 0.1 m, 2 deg)\n"
    "  --correlative-window M  local SLAM's correlative search: +-M m (0 = least squares only;\n"
    "                    default 0.15)\n"
    "  --correlative-translation-cost WT, --correlative-rotation-cost WR  its score discount\n"
    "                    exp(-(WT |dt|^2 + WR dtheta^2)) (defaults 0.1, 0.1)\n"
    "  --local-refinement  what refines local SLAM's correlative match: least-squares\n"
    "                    (default) or icp (MRPT's CICP against the submap's occupied cells)\n"
    "  --translation-weight W, --rotation-weight W  least-squares pull toward the odometry\n"
    "                    prediction (defaults 2, 10)\n"
    "  --search-min-points N, --search-voxel M  branch and bound scores each scan thinned by\n"
    "                    the coarsest voxel up to M m that leaves N points (defaults 150, 0.9;\n"
    "                    N = 0: every point)\n"
    "  --search-grid-factor F  branch and bound searches F x coarser cells than the submap\n"
    "                    (max-pooled; default 2); matches are refined and checked at full "
    "resolution\n"
    "  --refine-resolution M  before --trajectory is written, every scan is matched once more\n"
    "                    against the final map rendered at M m per cell (default 0.04; 0 = off:\n"
    "                    scans follow their nodes rigidly)\n"
    "  --alpha           confidence of RRR's chi-square tests (default 0.95)\n"
    "  --max-scans       stop after the first N scans of the log\n"
    "  --quiet           no progress line\n";

struct Arguments {
  std::string log;
  std::string output;
  std::string decisions;
  std::string trajectory;
  std::string map;
  double map_resolution = 0.05;
  bool quiet = false;
  frontend::TrajectoryRefinementParams refinement;
  std::size_t max_scans = 0;  ///< 0: all
  frontend::LaserSlamParams params;
};

Arguments parseArguments(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_slam_offline", kUsage);
  Arguments args;
  auto& p = args.params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto number = [&](double low, double high) {
      return cli.number(a, cli.value(i, a), low, high);
    };
    if (a == "--output" || a == "-o") {
      args.output = cli.value(i, a);
    } else if (a == "--decisions") {
      args.decisions = cli.value(i, a);
    } else if (a == "--trajectory") {
      args.trajectory = cli.value(i, a);
    } else if (a == "--map") {
      args.map = cli.value(i, a);
    } else if (a == "--map-resolution") {
      args.map_resolution = number(0.005, 10.0);
    } else if (a == "--scans-per-submap") {
      p.local.submap.scans_per_submap = static_cast<int>(number(2, 1e6));
    } else if (a == "--min-score") {
      p.loops.min_score = number(0.0, 1.0);
    } else if (a == "--max-constraint-distance") {
      p.loops.max_constraint_distance_m = number(0.0, 1e6);
    } else if (a == "--linear-window") {
      p.loops.window.linear_m = number(0.0, 1e3);
    } else if (a == "--angular-window") {
      p.loops.window.angular_rad = number(0.0, 180.0) * M_PI / 180.0;
    } else if (a == "--search-grid-factor") {
      p.local.submap.search_grid_factor = static_cast<int>(number(1, 16));
    } else if (a == "--depth") {
      p.local.submap.branch_and_bound_depth = static_cast<int>(number(1, 12));
    } else if (a == "--min-node-separation") {
      p.loops.min_node_separation = static_cast<int>(number(1, 1e9));
    } else if (a == "--submap-resolution") {
      p.local.submap.resolution_m = number(0.005, 1.0);
    } else if (a == "--voxel") {
      p.local.scan.voxel_size_m = number(0.001, 1.0);
    } else if (a == "--odometry-stddev") {
      const double xy = number(1e-6, 10.0);
      p.odometry_stddev = Eigen::Vector3d(xy, xy, xy / 2.0);
    } else if (a == "--loop-max-range") {
      p.loops.max_point_range_m = number(0.1, 1e3);
    } else if (a == "--min-travel") {
      p.local.motion_filter.min_travel_m = number(1e-6, 1e3);
    } else if (a == "--min-rotation") {
      p.local.motion_filter.min_rotation_rad = number(1e-6, 180.0) * M_PI / 180.0;
    } else if (a == "--pause-after-match") {
      p.loops.pause_after_match_nodes = static_cast<int>(number(0, 1e9));
    } else if (a == "--threads") {
      p.loops.threads = static_cast<int>(number(1, 256));
    } else if (a == "--search-every") {
      p.loops.search_every_n_nodes = static_cast<int>(number(1, 1e6));
    } else if (a == "--max-range") {
      p.local.scan.max_range_m = number(0.1, 1e3);
      p.local.submap.max_insertion_range_m = static_cast<float>(p.local.scan.max_range_m);
    } else if (a == "--correlative-window") {
      p.local.correlative.linear_window_m = number(0.0, 10.0);
      p.local.use_correlative_search = p.local.correlative.linear_window_m > 0.0;
    } else if (a == "--correlative-translation-cost") {
      p.local.correlative.translation_delta_cost_weight = number(0.0, 1e6);
    } else if (a == "--correlative-rotation-cost") {
      p.local.correlative.rotation_delta_cost_weight = number(0.0, 1e6);
    } else if (a == "--local-refinement") {
      const std::string v = cli.value(i, a);
      if (v == "least-squares") {
        p.local.refinement = frontend::LocalSlamParams::Refinement::kLeastSquares;
      } else if (v == "icp") {
        p.local.refinement = frontend::LocalSlamParams::Refinement::kIcp;
      } else {
        cli.fail("--local-refinement must be least-squares or icp, not '" + v + "'");
      }
    } else if (a == "--translation-weight") {
      p.local.least_squares.translation_weight = number(0.0, 1e6);
    } else if (a == "--rotation-weight") {
      p.local.least_squares.rotation_weight = number(0.0, 1e6);
    } else if (a == "--search-min-points") {
      p.loops.search_min_points = static_cast<int>(number(0, 1e6));
    } else if (a == "--search-voxel") {
      p.loops.search_voxel_max_m = number(0.001, 100.0);
    } else if (a == "--refine-resolution") {
      args.refinement.resolution_m = number(0.0, 10.0);
    } else if (a == "--alpha") {
      p.rrr.rrr.alpha = number(1e-6, 1.0 - 1e-9);
    } else if (a == "--max-scans") {
      args.max_scans = static_cast<std::size_t>(number(1, 1e12));
    } else if (a == "--quiet") {
      args.quiet = true;
    } else {
      cli.positional(a, args.log);
    }
  }
  if (args.log.empty()) cli.fail("no log file given");
  return args;
}

void writeTrajectory(const std::string& path, const std::vector<double>& stamps,
                     const std::vector<core::Pose2>& poses) {
  core::writeFileAtomically(path, [&](std::ostream& out) {
    out << "# t x y z qx qy qz qw (rrr_slam_offline; t = ipc_timestamp)\n" << std::fixed;
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const core::Pose2& x = poses[k];
      out << std::setprecision(6) << stamps[k] << ' ' << std::setprecision(6) << x.x() << ' '
          << x.y() << " 0 0 0 " << std::setprecision(9) << std::sin(0.5 * x.z()) << ' '
          << std::cos(0.5 * x.z()) << '\n';
    }
  });
}

// The optimized pose of each of the first n scans, refined against the final map (see
// trajectory_refinement.h) unless refinement is off.
std::vector<core::Pose2> refinedTrajectory(const frontend::LaserSlam& slam,
                                           const frontend::CarmenLog& log, std::size_t n,
                                           const frontend::TrajectoryRefinementParams& params) {
  std::vector<core::Pose2> poses = slam.scanMapPoses();
  if (params.resolution_m <= 0.0) return poses;
  const auto map = frontend::MatchGrid::fromOccupancyGrid(slam.renderMap(params.resolution_m),
                                                          slam.params().local.submap.unknown_value);
  std::vector<frontend::PointCloud> points(n);
  for (std::size_t k = 0; k < n; ++k) {
    points[k] = frontend::matchingPoints(frontend::RangeScan::fromCarmen(log.scans[k]),
                                         slam.params().local.scan);
  }
  return frontend::refineTrajectory(map, points, poses, params);
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
  try {
    const auto start = std::chrono::steady_clock::now();
    const frontend::CarmenLog log = frontend::readCarmenLog(args.log);
    frontend::LaserSlam slam(args.params);
    const bool progress = !args.quiet && isatty(STDERR_FILENO);
    const std::size_t n =
        args.max_scans > 0 ? std::min(args.max_scans, log.scans.size()) : log.scans.size();
    for (std::size_t k = 0; k < n; ++k) {
      const auto& record = log.scans[k];
      slam.addScan(frontend::RangeScan::fromCarmen(record), record.odom_pose);
      if (progress && (k % 100 == 0 || k + 1 == n)) {
        const auto status = slam.rrr().status();
        std::fprintf(
            stderr, "\r[slam] scan %zu/%zu  nodes %d  submaps %d  candidates %d  accepted %d   ",
            k + 1, n, status.nodes, slam.stats().submaps, status.candidates, status.accepted);
      }
    }
    if (progress) std::fprintf(stderr, "\n");
    slam.finish();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const auto& stats = slam.stats();
    const auto status = slam.rrr().status();
    const double duration = log.scans[n - 1].timestamp - log.scans.front().timestamp;

    std::printf("log            %s: %zu scans, %.1f s\n", args.log.c_str(), n, duration);
    std::printf("nodes          %d in %d submaps\n", stats.nodes, stats.submaps);
    std::printf("loop search    %lld node-submap pairs, %.2f ms each (%.2f s on %d threads)\n",
                stats.loop_searches,
                stats.loop_searches > 0 ? 1e3 * stats.loop_search_pair_seconds /
                                              static_cast<double>(stats.loop_searches)
                                        : 0.0,
                stats.loop_search_seconds, args.params.loops.threads);
    std::printf("candidates     %d in %d clusters\n", status.candidates, status.clusters);
    std::printf("accepted       %d\n", status.accepted);
    std::printf("rejected       %d\n", status.rejected);
    std::printf(
        "time           %.2f s (local SLAM %.2f, loop search %.2f, RRR %.2f), %.1fx real time\n",
        seconds, stats.local_slam_seconds, stats.loop_search_seconds, stats.rrr_seconds,
        seconds > 0 ? duration / seconds : 0.0);

    if (!args.output.empty()) {
      core::writePoseGraph(slam.rrr().mapPoseGraph(), args.output);
      std::printf("output         %s\n", args.output.c_str());
    }
    if (!args.decisions.empty()) {
      rrr::writeDecisions(args.decisions, slam.rrr().decisionRows());
      std::printf("decisions      %s\n", args.decisions.c_str());
    }
    if (!args.trajectory.empty()) {
      const auto refine_start = std::chrono::steady_clock::now();
      writeTrajectory(args.trajectory, slam.scanTimestamps(),
                      refinedTrajectory(slam, log, n, args.refinement));
      if (args.refinement.resolution_m > 0.0) {
        std::printf(
            "trajectory     %s (refined against the final map in %.2f s)\n",
            args.trajectory.c_str(),
            std::chrono::duration<double>(std::chrono::steady_clock::now() - refine_start).count());
      } else {
        std::printf("trajectory     %s\n", args.trajectory.c_str());
      }
    }
    if (!args.map.empty()) {
      const auto grid = slam.renderMap(args.map_resolution);
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
