#pragma once
// rrr_slam_offline's command line: its flags (the front end's parameter table under the ROS
// names, RRR's, the older flags still accepted), the usage text, and the checks between flags.

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "false_loops.h"
#include "params_cli.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_io.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/frontend/trajectory_refinement.h"
#include "rrr_params_cli.h"

namespace rrr_graphslam::tools::slam_offline {

// The flags this tool had before the front end's parameters got the ROS names (still accepted):
// old flag -> table name, and whether the old flag took degrees where the table takes radians.
struct FlagAlias {
  const char* flag;
  const char* name;
  bool degrees;
};
inline constexpr bool kDegree = true;
inline constexpr FlagAlias kAliases[] = {
    {"--linear-window", "linear_search_window", false},
    {"--angular-window", "angular_search_window", kDegree},
    {"--depth", "branch_and_bound_depth", false},
    {"--search-every", "search_every_n_nodes", false},
    {"--max-range", "scan_max_range", false},
    {"--loop-max-range", "loop_search_max_range", false},
    {"--voxel", "scan_voxel_size", false},
    {"--pause-after-match", "pause_after_match_nodes", false},
    {"--threads", "loop_search_threads", false},
    {"--min-travel", "scan_min_travel_m", false},
    {"--min-rotation", "scan_min_rotation_rad", kDegree},
    {"--correlative-window", "correlative_search_window", false},
    {"--translation-weight", "scan_translation_weight", false},
    {"--rotation-weight", "scan_rotation_weight", false},
    {"--search-min-points", "loop_search_min_points", false},
    {"--search-voxel", "loop_search_max_voxel", false},
};

inline auto slamTable = [](auto& p, auto&& f) { frontend::forEachSlamParam(p, f); };

inline std::string aliasUsage() {
  std::string text;
  for (const FlagAlias& alias : kAliases) {
    text += std::string("  ") + alias.flag + " V = " + tools::flagOf(alias.name) +
            (alias.degrees ? " V*pi/180 (V in degrees)" : " V") + "\n";
  }
  return text;
}

inline const std::string& usage() {
  static const std::string text =
      "usage: rrr_slam_offline LOG.clf[.gz] [--output GRAPH.g2o] [--decisions DECISIONS.tsv]\n"
      "                        [--trajectory TRAJ.txt] [--map MAP] [--map-resolution M]\n"
      "                        [--map-layering all|newest-session]\n"
      "                        [--map-hit-probability P] [--map-miss-probability P]\n"
      "                        [--refine-resolution M] [--max-scans N] [--quiet]\n"
      "                        [--decision-stream STREAM.tsv]\n"
      "                        [--load-map IN.rrrmap] [--save-map OUT.rrrmap]\n"
      "                        [--session-name NAME] [--session-trajectory TRAJ.txt]\n"
      "                        [--node-stamps STAMPS.txt]\n"
      "                        [--false-loops F [--false-loops-seed S]]\n"
      "                        [--initial-pose X,Y,THETA] [--localization-only]\n"
      "                        [--lifelong [--trim-overlap R] [--keep-recent-submaps N]\n"
      "                                    [--trim-rule overlap-ratio|fresh-area]\n"
      "                                    [--trim-min-fresh-area M2]\n"
      "                                    [--keep-current-session true|false]\n"
      "                                    [--sparsification clt|dense|delete]\n"
      "                                    [--clt-conservative true|false]\n"
      "                                    [--clt-per-edge-scaling true|false] [--trim-kl]\n"
      "                                    [--trim-group-neighbours]\n"
      "                                    [--trim-every-n-nodes N]]\n"
      "                        [--preset paper|default] [--PARAMETER V ...]\n"
      "  LOG               CARMEN log (FLASER or ROBOTLASER1 lines; the scans carry the odometry)\n"
      "  --output          the pose graph: nodes at their optimized poses, odometry and every "
      "loop\n"
      "                    candidate (rrr_offline can decide it again)\n"
      "  --node-stamps     'id timestamp session', one line per node of --output's graph:\n"
      "                    the ipc_timestamp of the node's scan and its session's index in the\n"
      "                    map (loaded sessions' nodes too), to score loops against a ground\n"
      "                    truth by time\n"
      "  --decisions       TSV 'from to cluster verdict reason', one row per loop candidate\n"
      "  --decision-stream TSV of the decisions as the run made them: a row per arrival and per\n"
      "                    verdict change, with the scan and node at which it happened and the\n"
      "                    scan's ipc_timestamp ('final' rows: the decision from scratch at the\n"
      "                    end; a loaded map's candidates have no arrival row)\n"
      "  --trajectory      optimized pose of every scan, TUM format 't x y z qx qy qz qw' with "
      "the\n"
      "                    log's ipc_timestamp\n"
      "  --map             writes MAP.pgm + MAP.yaml (map_server) and MAP.png (accepted loops\n"
      "                    green, rejected red)\n"
      "  --map-resolution  m per cell of the written map (default 0.05)\n"
      "  --map-layering all|newest-session  the written map from every scan alike (default), or\n"
      "                    each cell as the newest session that observed it saw it\n"
      "  --map-hit-probability P, --map-miss-probability P  per-ray update of the written map's\n"
      "                    cells a ray ends in / passes through (default 0.65 / 0.45; the submaps\n"
      "                    use 0.55 / 0.49, which leave cells seen by one pass unknown)\n"
      "  --refine-resolution M  before --trajectory is written, every scan is matched once more\n"
      "                    against the final map rendered at M m per cell (default 0.04; 0 = off:\n"
      "                    scans follow their nodes rigidly)\n"
      "  --max-scans       stop after the first N scans of the log\n"
      "  --load-map        start from a saved map: the log is mapped as a new session, in its own\n"
      "                    odometry frame; it joins the map once RRR accepts a loop to it\n"
      "  --save-map        write the map at the end (IN and OUT may be the same file)\n"
      "  --localization-only  with --load-map: the log is localized in the map, which stays as\n"
      "                    it is (no submap or scan of the log joins it; no --save-map)\n"
      "  --false-loops F   benchmarks: about F (0-0.9) of the loop candidates are false ones\n"
      "                    injected among the loop search's (close to a random older node;\n"
      "                    doc/lifelong.md); --false-loops-seed S (default 1) draws them\n"
      "  --session-name    this run's session name (default: the log's file name)\n"
      "  --session-trajectory  as --trajectory, for this run's session only\n"
      "  --initial-pose    with --load-map: where the log's first scan is in the map frame (m, m,\n"
      "                    rad); the map is searched around it instead of whole\n"
      "  --lifelong        with --save-map: before the map is saved, the submaps that newer ones\n"
      "                    cover are trimmed; their nodes are marginalized into marginal edges\n"
      "                    (doc/lifelong.md)\n"
      "  --trim-overlap R  a submap is trimmed when newer kept submaps cover this fraction of its\n"
      "                    observed cells (default 0.9)\n"
      "  --trim-rule       the coverage rule: overlap-ratio (Zhao et al., --trim-overlap; the\n"
      "                    default) or fresh-area (Cartographer's overlapping submaps trimmer:\n"
      "                    trimmed when the area only it observes is below --trim-min-fresh-area)\n"
      "  --trim-min-fresh-area M2  with --trim-rule fresh-area (m^2, default 2)\n"
      "  --keep-recent-submaps N  the newest N submaps are never trimmed (default 4)\n"
      "  --keep-current-session true|false  the newest session's submaps (this run's, if it\n"
      "                    added nodes) are never trimmed (default true: the map keeps the\n"
      "                    newest view of all it saw)\n"
      "  --sparsification  what replaces a trimmed submap's constraints: clt (Chow-Liu tree,\n"
      "                    default), dense (the exact marginal as one factor per piece of the\n"
      "                    blanket: for comparison; the graph grows denser where trims meet)\n"
      "                    or delete (nothing)\n"
      "  --clt-conservative true|false  the Chow-Liu tree's information scaled down to at\n"
      "                    most the marginal's (default true)\n"
      "  --clt-per-edge-scaling true|false  with it, each edge scaled on its own where\n"
      "                    that loses less (default true); false: one scale for all\n"
      "  --trim-kl         measure each trim's KL divergence (tree and deletion against the\n"
      "                    exact marginal: the trim_kl lines; slow on large maps); without it\n"
      "                    they say nan\n"
      "  --remember-trimmed-cells true|false  the cells a trimmed submap's scans decided\n"
      "                    stay in the written map where no newer session decides them\n"
      "                    (default true; false: they leave with the scans)\n"
      "  --trim-group-neighbours  marginalize the leaving nodes of neighbouring trimmed submaps\n"
      "                    together (one tree for all; larger blankets) instead of submap by\n"
      "                    submap\n"
      "  --trim-every-n-nodes N  also trim while mapping: every N nodes of this run's session,\n"
      "                    the earlier sessions' submaps that newer ones cover, and with\n"
      "                    --keep-current-session false its own older ones too (not before it\n"
      "                    is tied to the map, unless it is the map's first session; the\n"
      "                    submaps its undecided loops touch wait); an 'online_trim' line per\n"
      "                    trim (without it: only before the map is saved)\n"
      "  --quiet           no progress line\n" +
      tools::verifierUsage(true) +
      "The front end's parameters (the same names and units as the ROS parameters, with "
      "dashes):\n" +
      tools::tableUsage(frontend::LaserSlamParams{}, slamTable) +
      "RRR's parameters (the same names as the ROS parameters, with dashes):\n" +
      tools::rrrParamsUsage(rrr::OnlineRrrParams{}.rrr) + "Older flags, still accepted:\n" +
      aliasUsage() +
      "  --odometry-stddev M = --scan-odometry-stddev M,M,M/2\n"
      "  --local-refinement least-squares|icp = --scan-refinement least_squares|icp\n";
  return text;
}

struct Arguments {
  std::string log;
  std::string output;
  std::string decisions;
  std::string decision_stream;
  std::string trajectory;
  std::string map;
  double map_resolution = 0.05;
  frontend::MapLayering map_layering = frontend::MapLayering::kAllScans;
  frontend::MapRenderParams map_render;
  bool quiet = false;
  frontend::TrajectoryRefinementParams refinement;
  std::size_t max_scans = 0;  ///< 0: all
  std::string load_map;
  std::string save_map;
  bool localization_only = false;
  std::string session_name;
  std::string session_trajectory;
  std::string node_stamps;
  std::optional<core::Pose2> initial_pose;
  bool lifelong = false;
  frontend::TrimParams trim;
  int trim_every_n_nodes = 0;  ///< online trimming; 0: only at --save-map
  tools::FalseLoopParams false_loops;
  frontend::LaserSlamParams params;
};

// If argv[i] is one of kAliases, reads its value into the table's field (advancing i).
inline bool readAlias(const tools::CommandLine& cli, int& i, char** argv,
                      frontend::LaserSlamParams& p) {
  const std::string a = argv[i];
  for (const FlagAlias& alias : kAliases) {
    if (a != alias.flag) continue;
    const std::string text = cli.value(i, a);
    slamTable(p, [&](const core::ParamInfo& info, auto& field) {
      using T = std::decay_t<decltype(field)>;
      if constexpr (std::is_arithmetic_v<T>) {
        if (std::string(info.name) != alias.name) return;
        const double scale = alias.degrees ? 180.0 / M_PI : 1.0;
        const core::ParamInfo in_flag_units{alias.flag, info.low * scale, info.high * scale,
                                            info.doc};
        const double v = tools::parseNumber(cli, a, text);
        if (!(v >= in_flag_units.low && v <= in_flag_units.high))
          cli.fail(core::outOfRangeMessage(in_flag_units, text));
        if (std::is_integral_v<T> && v != std::floor(v))
          cli.fail(a + " must be an integer, not '" + text + "'");
        field = static_cast<T>(alias.degrees ? v * M_PI / 180.0 : v);
      }
    });
    return true;
  }
  if (a == "--odometry-stddev") {
    const double xy = cli.number(a, cli.value(i, a), 1e-6, 10.0);
    p.odometry_stddev = Eigen::Vector3d(xy, xy, xy / 2.0);
    return true;
  }
  if (a == "--local-refinement") {
    const std::string v = cli.value(i, a);
    if (v != "least-squares" && v != "icp")
      cli.fail("--local-refinement must be least-squares or icp, not '" + v + "'");
    p.local.refinement = v == "icp" ? frontend::LocalSlamParams::Refinement::kIcp
                                    : frontend::LocalSlamParams::Refinement::kLeastSquares;
    return true;
  }
  return false;
}

inline Arguments parseArguments(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_slam_offline", usage().c_str());
  Arguments args;
  auto& p = args.params;
  std::vector<std::string> trim_flags;
  tools::VerifierArguments verifier;
  tools::applyPresetArgument(cli, argc, argv, p.rrr.rrr);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--output" || a == "-o") {
      args.output = cli.value(i, a);
    } else if (a == "--decisions") {
      args.decisions = cli.value(i, a);
    } else if (a == "--decision-stream") {
      args.decision_stream = cli.value(i, a);
    } else if (a == "--trajectory") {
      args.trajectory = cli.value(i, a);
    } else if (a == "--map") {
      args.map = cli.value(i, a);
    } else if (a == "--map-resolution") {
      args.map_resolution = cli.number(a, cli.value(i, a), 0.005, 10.0);
    } else if (a == "--map-layering") {
      try {
        args.map_layering = frontend::parseMapLayering(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(e.what());
      }
    } else if (a == "--refine-resolution") {
      args.refinement.resolution_m = cli.number(a, cli.value(i, a), 0.0, 10.0);
    } else if (a == "--max-scans") {
      args.max_scans = static_cast<std::size_t>(cli.number(a, cli.value(i, a), 1, 1e12));
    } else if (a == "--quiet") {
      args.quiet = true;
    } else if (a == "--load-map") {
      args.load_map = cli.value(i, a);
    } else if (a == "--save-map") {
      args.save_map = cli.value(i, a);
    } else if (a == "--localization-only") {
      args.localization_only = true;
    } else if (a == "--lifelong") {
      args.lifelong = true;
    } else if (a == "--trim-overlap") {
      args.trim.trim_overlap_ratio = cli.number(a, cli.value(i, a), 1e-6, 1.0);
      trim_flags.push_back(a);
    } else if (a == "--trim-rule") {
      try {
        args.trim.trim_rule = frontend::parseTrimRule(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(std::string("--trim-rule: ") + e.what());
      }
      trim_flags.push_back(a);
    } else if (a == "--trim-min-fresh-area") {
      args.trim.trim_min_fresh_area_m2 = cli.number(a, cli.value(i, a), 0.0, 1e12);
      trim_flags.push_back(a);
    } else if (a == "--keep-recent-submaps") {
      args.trim.keep_recent_submaps = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1e9));
      trim_flags.push_back(a);
    } else if (a == "--keep-current-session") {
      args.trim.keep_current_session = cli.boolean(a, cli.value(i, a));
      trim_flags.push_back(a);
    } else if (a == "--trim-kl") {
      args.trim.report_kl = true;
      trim_flags.push_back(a);
    } else if (a == "--clt-conservative") {
      args.trim.chow_liu.conservative = cli.boolean(a, cli.value(i, a));
      trim_flags.push_back(a);
    } else if (a == "--clt-per-edge-scaling") {
      args.trim.chow_liu.per_edge_scaling = cli.boolean(a, cli.value(i, a));
      trim_flags.push_back(a);
    } else if (a == "--trim-every-n-nodes") {
      args.trim_every_n_nodes = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1e9));
      trim_flags.push_back(a);
    } else if (a == "--remember-trimmed-cells") {
      args.trim.remember_trimmed_cells = cli.boolean(a, cli.value(i, a));
      trim_flags.push_back(a);
    } else if (a == "--trim-group-neighbours") {
      args.trim.group_neighbours = true;
      trim_flags.push_back(a);
    } else if (a == "--sparsification") {
      try {
        args.trim.sparsification = frontend::parseSparsification(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(std::string("--sparsification: ") + e.what());
      }
      trim_flags.push_back(a);
    } else if (a == "--false-loops") {
      args.false_loops.fraction = cli.number(a, cli.value(i, a), 0.0, 0.9);
    } else if (a == "--false-loops-seed") {
      args.false_loops.seed =
          static_cast<unsigned>(cli.integer(a, cli.value(i, a), 0, 4294967295.0));
    } else if (a == "--session-name") {
      args.session_name = cli.value(i, a);
    } else if (a == "--session-trajectory") {
      args.session_trajectory = cli.value(i, a);
    } else if (a == "--node-stamps") {
      args.node_stamps = cli.value(i, a);
    } else if (a == "--initial-pose") {
      Eigen::Vector3d pose;
      tools::parseParam(cli, a, core::ParamInfo{"--initial-pose", -1e6, 1e6, ""}, cli.value(i, a),
                        pose);
      args.initial_pose = core::Pose2(pose[0], pose[1], core::normalizeAngle(pose[2]));
    } else if (tools::readTableParam(
                   cli, i, argv, args.map_render,
                   [](auto& r, auto&& f) { frontend::forEachMapRenderParam(r, f); }) ||
               tools::readTableParam(cli, i, argv, p, slamTable) ||
               tools::readRrrParam(cli, i, argv, p.rrr.rrr) || readAlias(cli, i, argv, p) ||
               tools::readVerifierArgument(cli, i, argv, verifier)) {
      continue;
    } else {
      cli.positional(a, args.log);
    }
  }
  tools::checkVerifierArguments(cli, verifier);
  p.rrr.verifier = verifier.choice;
  if (args.log.empty()) cli.fail("no log file given");
  if (args.initial_pose && args.load_map.empty()) cli.fail("--initial-pose needs --load-map");
  if (args.localization_only && args.load_map.empty()) {
    cli.fail("--localization-only needs --load-map (a map to localize in)");
  }
  if (args.localization_only && !args.save_map.empty()) {
    cli.fail("--localization-only leaves the loaded map as it is: there is nothing to --save-map");
  }
  if (!trim_flags.empty() && !args.lifelong) cli.fail(trim_flags.front() + " needs --lifelong");
  // The memory's cells are decided as the written map decides its cells.
  args.trim.memory_evidence = args.map_render;
  if (args.lifelong && args.save_map.empty()) {
    cli.fail("--lifelong trims the map when it is saved: it needs --save-map");
  }
  if (args.false_loops.fraction > 0.0 && args.trim_every_n_nodes > 0) {
    cli.fail(
        "--false-loops counts the loop search's candidates of one run: not with "
        "--trim-every-n-nodes, whose trims restart the front end");
  }
  if (args.trim_every_n_nodes > 0 &&
      args.trim.sparsification == frontend::Sparsification::kDelete) {
    cli.fail(
        "--trim-every-n-nodes needs --sparsification clt or dense: deletion would drop the "
        "running session's loops to the map with the trimmed nodes");
  }
  // A rule's threshold without its rule would be ignored: refused instead.
  auto given = [&](const char* flag) {
    return std::find(trim_flags.begin(), trim_flags.end(), flag) != trim_flags.end();
  };
  const bool fresh_area = args.trim.trim_rule == frontend::TrimRule::kFreshArea;
  if (given("--trim-min-fresh-area") && !fresh_area) {
    cli.fail("--trim-min-fresh-area is the fresh-area rule's: it needs --trim-rule fresh-area");
  }
  if (given("--trim-overlap") && fresh_area) {
    cli.fail("--trim-overlap is the overlap-ratio rule's: not with --trim-rule fresh-area");
  }
  if (args.trim_every_n_nodes > 0 && !args.decision_stream.empty()) {
    cli.fail(
        "--trim-every-n-nodes renumbers the loop candidates as it trims: it cannot be "
        "combined with --decision-stream");
  }
  if (args.lifelong) {
    args.trim.threads = p.loops.threads;
    try {
      frontend::validate(args.trim);
    } catch (const std::invalid_argument& e) {
      cli.fail(e.what());
    }
  }
  if (args.session_name.empty()) args.session_name = args.log.substr(args.log.rfind('/') + 1);
  try {
    frontend::validate(p);  // the ranges, and the rules between parameters
    rrr::validate(p.rrr);
  } catch (const std::invalid_argument& e) {
    cli.fail(e.what());
  }
  return args;
}

}  // namespace rrr_graphslam::tools::slam_offline
