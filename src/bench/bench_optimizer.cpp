// rrr_bench_optimizer: this package's optimizer against MRPT's optimize_graph_spa_levmarq on the
// same graphs in the same process (from the file's poses, and from rrr_optimize's automatic
// start: LAGO when the file's poses are far from a minimum), plus warm re-optimization after
// switching loop edges on.
// Prints Markdown tables; scripts/bench_optimizer runs it on the bundled graphs.
//
// usage: rrr_bench_optimizer [--repeat N] [--mrpt-max-iterations N] [--skip-mrpt]
//                            [--reopt GRAPH] [--reopt-edges K] GRAPH...

#include <mrpt/graphslam/levmarq.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/stopwatch.h"

namespace {

namespace core = rrr_graphslam::core;
using core::secondsSince;

struct Options {
  int repeat = 5;
  int mrpt_max_iterations = 100;
  bool skip_mrpt = false;
  std::string reopt_graph;
  int reopt_edges = 10;
  std::vector<std::string> graphs;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string nameOf(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  for (const std::string ext : {".gz", ".g2o", ".toro", ".graph"}) {
    if (name.size() > ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0) {
      name.resize(name.size() - ext.size());
    }
  }
  return name;
}

void benchGraph(const std::string& path, const Options& options) {
  const core::PoseGraph graph = core::readPoseGraph(path);

  // Runs alternate between the two optimizers and each side reports its median, so that the
  // machine's slow and fast spells (a shared VM) fall on both alike.
  std::vector<double> times, lago_times, mrpt_times;
  core::OptimizationResult ours, ours_lago;
  core::PoseGraph::Network network;
  std::size_t mrpt_iterations = 0;
  for (int r = 0; r < options.repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    core::Optimizer optimizer = core::makeOptimizer(graph);
    ours = optimizer.optimize();
    times.push_back(secondsSince(start));
    std::fprintf(stderr,
                 "%s: total %.1f ms, %d factorizations, optimize %.1f (structure %.1f, assemble "
                 "%.1f, factorize %.1f, solve %.1f)\n",
                 nameOf(path).c_str(), 1e3 * times.back(), ours.factorizations, 1e3 * ours.time_sec,
                 1e3 * ours.timing.structure_sec, 1e3 * ours.timing.assemble_sec,
                 1e3 * ours.timing.factorize_sec, 1e3 * ours.timing.solve_sec);
    // rrr_optimize's default start: LAGO's linear estimate when the file's poses are far from a
    // minimum (core::farFromMinimum), the file's otherwise; the check and LAGO are timed.
    const auto lago_start = std::chrono::steady_clock::now();
    core::Optimizer from_lago = core::makeOptimizer(graph);
    if (core::farFromMinimum(from_lago)) from_lago.setPoses(core::lagoInitialization(from_lago));
    ours_lago = from_lago.optimize();
    lago_times.push_back(secondsSince(lago_start));
    if (options.skip_mrpt) continue;
    network = graph.network();
    network.root = graph.nodeIds().front();
    mrpt::graphslam::TResultInfoSpaLevMarq info{};
    mrpt::containers::yaml params = mrpt::containers::yaml::Map();
    params["max_iterations"] = static_cast<uint64_t>(options.mrpt_max_iterations);
    const auto mrpt_start = std::chrono::steady_clock::now();
    mrpt::graphslam::optimize_graph_spa_levmarq(network, info, nullptr, params);
    mrpt_times.push_back(secondsSince(mrpt_start));
    mrpt_iterations = info.num_iters;
  }
  const double our_time = median(times);

  double mrpt_time = 0.0, mrpt_chi2 = 0.0;
  if (!options.skip_mrpt) {
    mrpt_time = median(mrpt_times);
    // Score MRPT's poses with our chi2 (sum of e^T Omega e), the same measure as ours.
    core::Optimizer scorer = core::makeOptimizer(graph);
    std::vector<core::Pose2> poses;
    for (const auto& [id, p] : network.nodes) poses.emplace_back(p.x(), p.y(), p.phi());
    scorer.setPoses(poses);
    mrpt_chi2 = scorer.chi2();
  }

  const double lago_time = median(lago_times);
  std::printf("| %s | %zu | %zu | %.1f | %.6g | %d | %.1f | %.6g | %d |", nameOf(path).c_str(),
              graph.numNodes(), graph.numEdges(), 1e3 * our_time, ours.final_chi2, ours.iterations,
              1e3 * lago_time, ours_lago.final_chi2, ours_lago.iterations);
  if (options.skip_mrpt) {
    std::printf(" - | - | - | - | - |\n");
  } else {
    std::printf(" %.1f | %.6g | %zu | %.1fx | %.1fx |\n", 1e3 * mrpt_time, mrpt_chi2,
                mrpt_iterations, mrpt_time / our_time, mrpt_time / lago_time);
  }
  std::fflush(stdout);
}

void benchReoptimization(const std::string& path, const Options& options) {
  const core::PoseGraph graph = core::readPoseGraph(path);
  std::vector<int> loops;
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    if (graph.edge(k).kind == core::EdgeKind::kLoopCandidate) loops.push_back(static_cast<int>(k));
  }
  std::printf(
      "\n| re-optimization | graph | edges switched on | median ms | max ms | iterations | "
      "factorizations |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  // The same trials twice: a fresh factorization per re-optimization, then the last
  // factorization brought up to date by rank updates (OptimizerParams::factor_updates).
  for (const bool updates : {false, true}) {
    core::OptimizerParams params;
    params.factor_updates = updates;
    core::Optimizer optimizer = core::makeOptimizer(graph, params);
    optimizer.optimize();  // converged with every edge; the pattern covers all of them

    std::mt19937 rng(1);
    std::vector<int> order = loops;
    std::vector<double> times;
    int iterations = 0;
    int factorizations = 0;
    for (int trial = 0; trial < 5; ++trial) {
      std::shuffle(order.begin(), order.end(), rng);
      const std::vector<int> chosen(order.begin(), order.begin() + options.reopt_edges);
      for (int c : chosen) optimizer.setActive(c, false);
      optimizer.optimize();  // converged without them
      for (int c : chosen) optimizer.setActive(c, true);
      const core::OptimizationResult r = optimizer.optimize();
      times.push_back(r.time_sec);
      iterations += r.iterations;
      factorizations += r.factorizations;
      std::fprintf(stderr,
                   "reopt%s trial %d: %.1f ms (structure %.1f, assemble %.1f, factorize/update "
                   "%.1f, solve %.1f), chi2 %.6g\n",
                   updates ? " (rank updates)" : "", trial, 1e3 * r.time_sec,
                   1e3 * r.timing.structure_sec, 1e3 * r.timing.assemble_sec,
                   1e3 * r.timing.factorize_sec, 1e3 * r.timing.solve_sec, r.final_chi2);
    }
    std::printf("| warm, converged start%s | %s | %d | %.1f | %.1f | %.1f | %.1f |\n",
                updates ? ", rank-updated factor" : "", nameOf(path).c_str(), options.reopt_edges,
                1e3 * median(times), 1e3 * *std::max_element(times.begin(), times.end()),
                iterations / 5.0, factorizations / 5.0);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "rrr_bench_optimizer: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--repeat") {
      options.repeat = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--mrpt-max-iterations") {
      options.mrpt_max_iterations = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--skip-mrpt") {
      options.skip_mrpt = true;
    } else if (a == "--reopt") {
      options.reopt_graph = value();
    } else if (a == "--reopt-edges") {
      options.reopt_edges = std::max(1, std::atoi(value().c_str()));
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "rrr_bench_optimizer: unknown option " << a << "\n";
      return 2;
    } else {
      options.graphs.push_back(a);
    }
  }
  try {
    std::printf(
        "| graph | nodes | edges | ours ms | ours chi2 | ours iters | auto start ms | chi2 | "
        "iters "
        "| MRPT ms | MRPT chi2 | MRPT iters | speed-up | speed-up, auto start |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& g : options.graphs) benchGraph(g, options);
    if (!options.reopt_graph.empty()) benchReoptimization(options.reopt_graph, options);
  } catch (const std::exception& e) {
    std::cerr << "rrr_bench_optimizer: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
