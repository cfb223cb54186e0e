// rrr_bench_trim: the lifelong trim of saved maps, timed trim by trim, against the cost of one
// optimization of the same map's trusted graph in the same run (what every trim paid before the
// trims shared one). Prints a Markdown table; scripts/bench_trim makes the maps and runs it.
//
// usage: rrr_bench_trim [--sparsification clt|delete] [--trim-overlap R]
//                       [--keep-recent-submaps N] [--keep-current-session true|false]
//                       [--clt-conservative true|false] [--clt-per-edge-scaling true|false]
//                       [--group-neighbours] [--no-kl]
//                       [--repeat N] MAP.rrrmap...
// The maps must have been made with the default front-end parameters (the coverage grids are
// built with them).

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "../tools/command_line.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/core/quantile.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/frontend/laser_slam_params.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/map_trimming.h"

namespace {

namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;

struct Options {
  frontend::TrimParams trim;
  int repeat = 3;
  std::vector<std::string> maps;
};

constexpr const char* kUsage =
    "usage: rrr_bench_trim [--sparsification clt|delete] [--trim-overlap R] "
    "[--trim-rule overlap-ratio|fresh-area] [--trim-min-fresh-area M2] "
    "[--keep-recent-submaps N] [--keep-current-session true|false] "
    "[--clt-conservative true|false] [--clt-per-edge-scaling true|false] "
    "[--group-neighbours] [--no-kl] [--repeat N] MAP.rrrmap...\n";

// Nearest rank over every trim (0 for none).
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return core::nearestRank(v, q);
}

// The baseline: one optimization of the map's trusted graph (odometry, accepted loops, marginal
// edges) from its stored poses, as each trim did before the trims shared one.
double optimizeOnce(const frontend::MapSnapshot& map) {
  const core::PoseGraph graph = frontend::trustedPoseGraph(map);
  const core::Clock::time_point watch = core::Clock::now();
  core::Optimizer optimizer = core::makeOptimizer(graph);
  optimizer.optimize();
  return core::secondsSince(watch);
}

}  // namespace

int main(int argc, char** argv) {
  const rrr_graphslam::tools::CommandLine cli(argc, argv, "rrr_bench_trim", kUsage);
  Options options;
  options.trim.report_kl = true;
  bool overlap_given = false, fresh_area_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--sparsification") {
      try {
        options.trim.sparsification = frontend::parseSparsification(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(a + ": " + e.what());
      }
    } else if (a == "--trim-overlap") {
      options.trim.trim_overlap_ratio = cli.number(a, cli.value(i, a), 1e-6, 1.0);
      overlap_given = true;
    } else if (a == "--trim-rule") {
      try {
        options.trim.trim_rule = frontend::parseTrimRule(cli.value(i, a));
      } catch (const std::invalid_argument& e) {
        cli.fail(a + ": " + e.what());
      }
    } else if (a == "--trim-min-fresh-area") {
      options.trim.trim_min_fresh_area_m2 = cli.number(a, cli.value(i, a), 0.0, 1e12);
      fresh_area_given = true;
    } else if (a == "--keep-recent-submaps") {
      options.trim.keep_recent_submaps = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1e9));
    } else if (a == "--keep-current-session") {
      options.trim.keep_current_session = cli.boolean(a, cli.value(i, a));
    } else if (a == "--clt-conservative") {
      options.trim.chow_liu.conservative = cli.boolean(a, cli.value(i, a));
    } else if (a == "--clt-per-edge-scaling") {
      options.trim.chow_liu.per_edge_scaling = cli.boolean(a, cli.value(i, a));
    } else if (a == "--group-neighbours") {
      options.trim.group_neighbours = true;
    } else if (a == "--no-kl") {
      options.trim.report_kl = false;
    } else if (a == "--repeat") {
      options.repeat = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1e9));
    } else if (!a.empty() && a[0] == '-') {
      cli.fail("unknown option " + a);
    } else {
      options.maps.push_back(a);
    }
  }
  if (options.maps.empty()) cli.fail("no map given");
  // A rule's threshold without its rule would be ignored: refused, as rrr_slam_offline does.
  const bool fresh_area = options.trim.trim_rule == frontend::TrimRule::kFreshArea;
  if (fresh_area_given && !fresh_area)
    cli.fail("--trim-min-fresh-area needs --trim-rule fresh-area");
  if (overlap_given && fresh_area) cli.fail("--trim-overlap is not with --trim-rule fresh-area");
  try {
    frontend::validate(options.trim);
    const frontend::SubmapParams submap = frontend::LaserSlamParams{}.local.submap;
    std::printf(
        "| map | nodes | submaps trimmed | trims | blanket max | trim p50 / p99 / max (ms) | trim "
        "p99, blankets <= 100 (ms) | KL measurement per trim p50 (ms) | one optimization of the "
        "map (ms) | trim p99 / optimization | KL clt / delete (nats, summed) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& path : options.maps) {
      const frontend::MapSnapshot map = frontend::readMapFile(path);
      std::vector<double> trim_ms, small_ms, kl_ms, optimize_ms;
      frontend::TrimReport report;
      // Runs alternate between the trim and the baseline, so that the machine's slow and fast
      // spells fall on both alike; every trim of every run counts.
      for (int r = 0; r < options.repeat; ++r) {
        report = frontend::trimMap(map, options.trim, submap).report;
        for (const frontend::TrimRecord& t : report.trims) {
          trim_ms.push_back(1e3 * t.seconds);
          if (t.blanket_nodes <= 100) small_ms.push_back(1e3 * t.seconds);
          kl_ms.push_back(1e3 * t.kl_seconds);
        }
        optimize_ms.push_back(1e3 * optimizeOnce(map));
      }
      int blanket = 0;
      double kl_clt = 0.0, kl_delete = 0.0;
      for (const frontend::TrimRecord& t : report.trims) {
        blanket = std::max(blanket, t.blanket_nodes);
        kl_clt += t.kl_clt_nats;
        kl_delete += t.kl_delete_nats;
      }
      char kl[64] = "–";
      if (options.trim.report_kl) std::snprintf(kl, sizeof(kl), "%.3g / %.3g", kl_clt, kl_delete);
      char kl_ms_text[32] = "–";
      if (options.trim.report_kl) {
        std::snprintf(kl_ms_text, sizeof(kl_ms_text), "%.2f", quantile(kl_ms, 0.5));
      }
      const double p99 = quantile(trim_ms, 0.99);
      const double optimize = quantile(optimize_ms, 0.5);
      std::printf(
          "| %s | %zu | %d | %zu | %d | %.2f / %.2f / %.2f | %.2f | %s | %.1f | %.3f | %s |\n",
          std::filesystem::path(path).filename().c_str(), map.nodes.size(), report.trimmed_submaps,
          report.trims.size(), blanket, quantile(trim_ms, 0.5), p99, quantile(trim_ms, 1.0),
          quantile(small_ms, 0.99), kl_ms_text, optimize, optimize > 0.0 ? p99 / optimize : 0.0,
          kl);
    }
  } catch (const std::exception& e) {
    std::cerr << "rrr_bench_trim: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
