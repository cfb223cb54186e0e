// rrr_optimize INPUT --output OUTPUT.g2o [--method gn|lm] [--max-iterations N]
// Optimizes a g2o/TORO pose graph with every edge trusted and writes the optimized graph. Exits 1,
// writing nothing, when the optimization does not converge (the stop reason is printed).

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <iostream>
#include <string>

#include "command_line.h"
#include "rrr_graphslam/core/blas_kernel.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/core/optimizer.h"

namespace {

namespace tools = rrr_graphslam::tools;
using rrr_graphslam::core::OptimizerParams;

const char* const kUsage =
    "usage: rrr_optimize INPUT --output OUTPUT.g2o [--method gn|lm] [--max-iterations N]\n"
    "                    [--init auto|file|lago] [--lago]\n"
    "  INPUT            g2o (VERTEX_SE2/EDGE_SE2) or TORO (VERTEX2/EDGE2) file, .gz allowed\n"
    "  --output FILE    optimized graph; TORO if it ends in .graph or .toro, g2o otherwise\n"
    "  --method gn|lm   Gauss-Newton (default) or Levenberg-Marquardt\n"
    "  --max-iterations N   default 50; 0 writes the start poses unoptimized\n"
    "  --init auto|file|lago  start from the file's poses or from the linear (LAGO) estimate;\n"
    "                   auto (default): LAGO when the file's poses are far from a minimum (chi2\n"
    "                   above 100 per constraint)\n"
    "  --lago           same as --init lago\n";

struct Arguments {
  std::string input;
  std::string output;
  OptimizerParams params;
  enum class Init { kAuto, kFile, kLago } init = Init::kAuto;
};

Arguments parseArguments(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_optimize", kUsage);
  Arguments args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--output" || a == "-o") {
      args.output = cli.value(i, a);
    } else if (a == "--method") {
      const std::string m = cli.value(i, a);
      if (m == "gn") {
        args.params.method = OptimizerParams::Method::kGaussNewton;
      } else if (m == "lm") {
        args.params.method = OptimizerParams::Method::kLevenbergMarquardt;
      } else {
        cli.fail("--method must be gn or lm, not '" + m + "'");
      }
    } else if (a == "--lago") {
      args.init = Arguments::Init::kLago;
    } else if (a == "--init") {
      const std::string m = cli.value(i, a);
      if (m == "auto") {
        args.init = Arguments::Init::kAuto;
      } else if (m == "file") {
        args.init = Arguments::Init::kFile;
      } else if (m == "lago") {
        args.init = Arguments::Init::kLago;
      } else {
        cli.fail("--init must be auto, file or lago, not '" + m + "'");
      }
    } else if (a == "--max-iterations") {
      args.params.max_iterations = static_cast<int>(cli.integer(a, cli.value(i, a), 0.0, 1e9));
    } else {
      cli.positional(a, args.input);
    }
  }
  if (args.input.empty()) cli.fail("no input file given");
  if (args.output.empty()) cli.fail("--output is required");
  return args;
}

}  // namespace

int main(int argc, char** argv) {
  namespace core = rrr_graphslam::core;
  const Arguments args = parseArguments(argc, argv);
  if (const auto warning = core::blasKernelWarning())
    std::fprintf(stderr, "warning: %s\n", warning->c_str());
  try {
    const auto load_start = std::chrono::steady_clock::now();
    core::PoseGraph graph = core::readPoseGraph(args.input);
    const double load_sec =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    std::printf("input          %s: %zu nodes, %zu edges (read in %.3f s)\n", args.input.c_str(),
                graph.numNodes(), graph.numEdges(), load_sec);

    core::Optimizer optimizer = core::makeOptimizer(graph, args.params);
    const std::clock_t cpu_start = std::clock();  // the process's CPU time: every thread's
    const auto init_start = std::chrono::steady_clock::now();
    const bool lago = args.init == Arguments::Init::kLago ||
                      (args.init == Arguments::Init::kAuto && core::farFromMinimum(optimizer));
    if (lago) optimizer.setPoses(core::lagoInitialization(optimizer));
    const double init_sec =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - init_start).count();
    const std::clock_t cpu_init_end = std::clock();
    std::printf("initialization %s\n", lago ? "lago" : "file");
    const core::OptimizationResult result = optimizer.optimize();
    const std::clock_t cpu_end = std::clock();
    auto cpu_seconds = [](std::clock_t from, std::clock_t to) {
      return static_cast<double>(to - from) / CLOCKS_PER_SEC;
    };
    std::printf("method         %s\n", args.params.method == OptimizerParams::Method::kGaussNewton
                                           ? "gauss-newton"
                                           : "levenberg-marquardt");
    std::printf("initial chi2   %.6f\n", result.initial_chi2);
    std::printf("final chi2     %.6f\n", result.final_chi2);
    std::printf("iterations     %d\n", result.iterations);
    std::printf("time           %.4f s (initialization %.4f s, optimization %.4f s)\n",
                init_sec + result.time_sec, init_sec, result.time_sec);
    // CPU time, which other processes on a busy machine do not stretch (every thread counted).
    std::printf("cpu time       %.4f s (initialization %.4f s, optimization %.4f s)\n",
                cpu_seconds(cpu_start, cpu_end), cpu_seconds(cpu_start, cpu_init_end),
                cpu_seconds(cpu_init_end, cpu_end));
    std::printf("stop reason    %s\n", core::toString(result.stop_reason).c_str());

    // Only a minimum is written (or, with --max-iterations 0, the start as asked): a run that did
    // not converge, or poses that are not finite, are an error and leave no file.
    const bool asked_no_steps = args.params.max_iterations == 0;
    if (!result.converged() && !asked_no_steps) {
      std::cerr << "rrr_optimize: " << args.input << ": the optimization did not converge ("
                << core::toString(result.stop_reason) << ", chi2 " << result.final_chi2
                << "); nothing written\n";
      return 1;
    }
    for (int n = 0; n < optimizer.numNodes(); ++n) {
      const core::Pose2& p = optimizer.poses()[static_cast<std::size_t>(n)];
      if (!p.allFinite()) {
        std::cerr << "rrr_optimize: " << args.input << ": node "
                  << graph.nodeIds()[static_cast<std::size_t>(n)]
                  << " has a non-finite pose after the optimization; nothing written\n";
        return 1;
      }
    }
    core::copyPosesToGraph(optimizer, graph);
    core::writePoseGraph(graph, args.output);
    std::printf("output         %s\n", args.output.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_optimize: " << e.what() << "\n";
    return 1;
  }
}
