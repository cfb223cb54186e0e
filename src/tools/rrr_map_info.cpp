// rrr_map_info MAP.rrrmap [--graph OUT.g2o] [--trajectory OUT.txt] [--map OUT] [--map-resolution M]
// What a saved map holds, as `key value` lines; exports its graph (g2o, map poses) and its
// occupancy map (map_server PGM + YAML).

#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "command_line.h"
#include "params_cli.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/map_io.h"
#include "rrr_graphslam/frontend/map_render.h"
#include "tum_trajectory.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;
namespace rrr = rrr_graphslam::rrr;

const char* const kUsage =
    "usage: rrr_map_info MAP.rrrmap [--graph OUT.g2o] [--trajectory OUT.txt] [--map OUT]\n"
    "                    [--map-resolution M] [--map-layering all|newest-session]\n"
    "                    [--map-hit-probability P] [--map-miss-probability P]\n"
    "                    [--remembered-cells true|false]\n"
    "  MAP             a map saved by rrr_slam_offline --save-map (or the node's ~save_map)\n"
    "  --graph         writes the graph: nodes at their map poses, odometry and every loop\n"
    "                  candidate, and dense factors as RRR_DENSE_SE2 lines (g2o, or TORO for\n"
    "                  .graph/.toro, which cannot hold dense factors)\n"
    "  --trajectory    writes every node's map pose with its scan's timestamp (TUM format, as\n"
    "                  rrr_slam_offline --trajectory)\n"
    "  --map           writes OUT.pgm + OUT.yaml (map_server) from every node's scan and\n"
    "                  the cells remembered of trimmed submaps (doc/lifelong.md)\n"
    "  --remembered-cells  false: --map from the nodes' scans alone (default true)\n"
    "  --map-resolution  m per cell of --map (default 0.05)\n"
    "  --map-layering  all (default): every scan weighs alike; newest-session: each cell as the\n"
    "                  newest session that observed it saw it (a world that changed between\n"
    "                  sessions shown as it is now)\n"
    "  --map-hit-probability P, --map-miss-probability P  per-ray update of the map's cells a\n"
    "                  ray ends in / passes through (default 0.65 / 0.45; the submaps use 0.55 /\n"
    "                  0.49, which leave cells seen by one pass unknown)\n"
    "Prints 'key value' lines: format_version, sessions, nodes, edges, odometry_edges,\n"
    "loop_edges, loop_edges_accepted, loop_edges_rejected, loop_edges_pending, marginal_edges,\n"
    "dense_factors, dense_factor_nodes (their nodes, summed),\n"
    "submaps, scans, trimmed_submaps, marginalized_nodes, remembered_patches, remembered_cells,\n"
    "bytes, then 'session K nodes N start_time T number M name NAME' per session (M: its\n"
    "place in the map's life, kept when trimming removes earlier sessions) and every parameter "
    "the\n"
    "map was made with as 'param NAME VALUE'.\n";

std::string paramOf(const frontend::MapSnapshot& map, const std::string& name) {
  for (const auto& [key, value] : map.params) {
    if (key == name) return value;
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_map_info", kUsage);
  std::string path, graph_out, trajectory_out, map_out;
  double resolution = 0.05;
  frontend::MapLayering layering = frontend::MapLayering::kAllScans;
  frontend::MapRenderParams render;
  bool remembered = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--graph") {
      graph_out = cli.value(i, a);
    } else if (a == "--trajectory") {
      trajectory_out = cli.value(i, a);
    } else if (a == "--map") {
      map_out = cli.value(i, a);
    } else if (a == "--map-resolution") {
      resolution = cli.number(a, cli.value(i, a), 0.005, 10.0);
    } else if (a == "--remembered-cells") {
      remembered = cli.boolean(a, cli.value(i, a));
    } else if (a == "--map-layering") {
      try {
        layering = frontend::parseMapLayering(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(e.what());
      }
    } else if (!tools::readTableParam(cli, i, argv, render, [](auto& r, auto&& f) {
                 frontend::forEachMapRenderParam(r, f);
               })) {
      cli.positional(a, path);
    }
  }
  if (path.empty()) cli.fail("no map file given");
  try {
    const frontend::MapSnapshot map = frontend::readMapFile(path);
    std::size_t odometry = 0, loops = 0, accepted = 0, rejected = 0, pending = 0, marginal = 0;
    // Per loop source (choices(LoopSource) order): candidates, and those accepted.
    const auto sources = choices(frontend::LoopSource{});
    std::vector<std::size_t> by_source(sources.size(), 0), accepted_by_source(sources.size(), 0);
    for (const auto& e : map.edges) {
      if (e.kind == frontend::MapSnapshot::EdgeKind::kOdometry) {
        ++odometry;
      } else if (e.kind == frontend::MapSnapshot::EdgeKind::kLoopCandidate) {
        ++loops;
        accepted += e.verdict == rrr::Verdict::kAccepted;
        rejected += e.verdict == rrr::Verdict::kRejected;
        pending += e.verdict == rrr::Verdict::kPending;
        const auto source = static_cast<std::size_t>(e.source);
        ++by_source.at(source);
        accepted_by_source.at(source) += e.verdict == rrr::Verdict::kAccepted;
      } else {
        ++marginal;
      }
    }
    struct stat info {};
    const long long bytes = ::stat(path.c_str(), &info) == 0 ? info.st_size : -1;
    std::printf("format_version %u\n", map.format_version);
    std::printf("sessions %zu\n", map.sessions.size());
    std::printf("nodes %zu\n", map.nodes.size());
    std::printf("edges %zu\n", map.edges.size());
    std::printf("odometry_edges %zu\n", odometry);
    std::printf("loop_edges %zu\n", loops);
    std::printf("loop_edges_accepted %zu\n", accepted);
    std::printf("loop_edges_rejected %zu\n", rejected);
    std::printf("loop_edges_pending %zu\n", pending);
    for (std::size_t k = 0; k < sources.size(); ++k) {
      std::string name = sources[k].second;  // local-search -> loop_edges_local_search
      std::replace(name.begin(), name.end(), '-', '_');
      if (name == "unknown") name = "unknown_source";
      std::printf("loop_edges_%s %zu\n", name.c_str(), by_source[k]);
      std::printf("loop_edges_%s_accepted %zu\n", name.c_str(), accepted_by_source[k]);
    }
    std::printf("marginal_edges %zu\n", marginal);
    std::size_t dense_nodes = 0;
    for (const core::DenseFactor& f : map.dense_factors) dense_nodes += f.nodes.size();
    std::printf("dense_factors %zu\n", map.dense_factors.size());
    std::printf("dense_factor_nodes %zu\n", dense_nodes);
    std::printf("submaps %zu\n", map.submaps.size());
    std::printf("scans %zu\n", map.nodes.size());  // one scan per node
    std::printf("trimmed_submaps %d\n", map.lifelong.trimmed_submaps);
    std::printf("marginalized_nodes %d\n", map.lifelong.marginalized_nodes);
    std::printf("remembered_patches %zu\n", map.memory.size());
    std::printf("remembered_cells %zu\n", frontend::rememberedCells(map.memory));
    std::printf("bytes %lld\n", bytes);
    for (std::size_t s = 0; s < map.sessions.size(); ++s) {
      const int end = s + 1 < map.sessions.size() ? map.sessions[s + 1].first_node
                                                  : static_cast<int>(map.nodes.size());
      std::printf("session %zu nodes %d start_time %.6f number %d name %s\n", s,
                  end - map.sessions[s].first_node, map.sessions[s].start_time,
                  map.sessions[s].number, map.sessions[s].name.c_str());
    }
    for (const auto& [name, value] : map.params) {
      std::printf("param %s %s\n", name.c_str(), value.c_str());
    }
    if (!graph_out.empty()) {
      core::writePoseGraph(frontend::mapPoseGraph(map), graph_out);
      std::printf("graph %s\n", graph_out.c_str());
    }
    if (!trajectory_out.empty()) {
      std::vector<double> stamps;
      std::vector<core::Pose2> poses;
      for (const auto& node : map.nodes) {
        stamps.push_back(node.timestamp);
        poses.push_back(node.map_pose);
      }
      tools::writeTumTrajectory(trajectory_out, "rrr_map_info", stamps, poses);
      std::printf("trajectory %s\n", trajectory_out.c_str());
    }
    if (!map_out.empty()) {
      frontend::MapInputs inputs = frontend::renderInputs(map);
      if (!remembered) inputs.memory.clear();
      inputs.layering = layering;
      inputs.render = render;
      const std::string range = paramOf(map, "scan_max_range");
      if (!range.empty()) {
        char* end = nullptr;
        const double r = std::strtod(range.c_str(), &end);
        if (end == range.c_str() || *end != '\0' || !(r > 0.0 && r < 1e6)) {
          throw std::invalid_argument(path + ": parameter scan_max_range '" + range +
                                      "' is not a positive number");
        }
        inputs.insertion.max_insertion_range_m = static_cast<float>(r);
      }
      frontend::writeMapServerFiles(frontend::renderOccupancyMap(inputs, resolution), map_out);
      std::printf("map %s.pgm %s.yaml\n", map_out.c_str(), map_out.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_map_info: " << e.what() << "\n";
    return 1;
  }
}
