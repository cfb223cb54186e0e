// rrr_offline INPUT [--decisions DECISIONS.tsv] [--output OPTIMIZED.g2o]
//             [--mode batch|incremental] [--verifier rrr|pcm|scgp|gnc] [--preset paper|default]
//             [--alpha 0.95] ...
// Decides which loop candidates of a pose graph are real (RRR, or another verifier for
// comparison: rrr/verifier.h) and writes the decisions and the graph optimized with the accepted
// loops.

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <utility>

#include "command_line.h"
#include "decision_stream.h"
#include "rrr_graphslam/core/blas_kernel.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/rrr/decisions_io.h"
#include "rrr_graphslam/rrr/incremental_rrr.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/verifier_choice.h"
#include "rrr_params_cli.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace rrr = rrr_graphslam::rrr;

const std::string& usage() {
  static const std::string text =
      "usage: rrr_offline INPUT [--decisions DECISIONS.tsv] [--output OPTIMIZED.g2o]\n"
      "                   [--mode batch|incremental] [--verifier rrr|pcm|scgp|gnc]\n"
      "                   [--preset paper|default] [--PARAMETER V ...] [--profile] [--quiet]\n"
      "  INPUT            g2o or TORO pose graph (.gz allowed); edges with |from-to| != 1 are\n"
      "                   loop candidates, the others trusted odometry\n"
      "  --decisions      TSV with header 'from to cluster verdict reason', one row per candidate\n"
      "  --output         the graph with odometry and accepted loops, optimized\n"
      "  --mode           batch (default) or incremental (candidates fed in node order)\n"
      "  --decision-stream  with --mode incremental: TSV of every arrival and verdict change as\n"
      "                   the replay made them (rrr_slam_offline's format; scan = nodes arrived,\n"
      "                   stamp = seconds since the replay started)\n"
      "  --profile        where the time went: per named RRR step its calls, own wall time,\n"
      "                   optimizations and numeric factorizations (count, time, mean flops)\n"
      "  --quiet          no progress line\n" +
      tools::verifierUsage(false) +
      "RRR's parameters (the same names as the ROS parameters, with dashes):\n" +
      tools::rrrParamsUsage() +
      "Shorthands: --full-intra (--reduced-intra-graph false), --keep-mixed-clusters\n"
      "  (--split-mixed-clusters false), --fresh-factorizations (--incremental-factor-updates\n"
      "  false), --rebatch-every N (--incremental-rebatch-every N), --no-joint-link-check\n"
      "  (--joint-link-check false).\n";
  return text;
}

struct Arguments {
  std::string input;
  std::string decisions;
  std::string output;
  std::string decision_stream;
  bool incremental = false;
  bool quiet = false;
  bool profile = false;
  tools::VerifierArguments verifier;
  rrr::RrrParams params;
};

Arguments parseArguments(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_offline", usage().c_str());
  Arguments args;
  tools::applyPresetArgument(cli, argc, argv, args.params);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--decisions") {
      args.decisions = cli.value(i, a);
    } else if (a == "--output" || a == "-o") {
      args.output = cli.value(i, a);
    } else if (a == "--mode") {
      const std::string m = cli.value(i, a);
      if (m != "batch" && m != "incremental") cli.fail("--mode must be batch or incremental");
      args.incremental = m == "incremental";
    } else if (a == "--decision-stream") {
      args.decision_stream = cli.value(i, a);
    } else if (tools::readVerifierArgument(cli, i, argv, args.verifier) ||
               tools::readRrrParam(cli, i, argv, args.params)) {
      continue;
    } else if (a == "--full-intra") {
      args.params.reduced_intra_graph = false;
    } else if (a == "--keep-mixed-clusters") {
      args.params.split_mixed_clusters = false;
    } else if (a == "--fresh-factorizations") {
      args.params.incremental_factor_updates = false;
    } else if (a == "--rebatch-every") {
      args.params.incremental_rebatch_every =
          static_cast<int>(cli.number(a, cli.value(i, a), 0, 1e9));
    } else if (a == "--no-joint-link-check") {
      args.params.joint_link_check = false;
    } else if (a == "--quiet") {
      args.quiet = true;
    } else if (a == "--profile") {
      args.profile = true;
    } else {
      cli.positional(a, args.input);
    }
  }
  if (args.input.empty()) cli.fail("no input file given");
  tools::checkVerifierArguments(cli, args.verifier);
  if (!args.decision_stream.empty() && !args.incremental) {
    cli.fail("--decision-stream needs --mode incremental (a batch decision has no stream)");
  }
  if (args.incremental && args.verifier.choice.verifier != rrr::Verifier::kRrr) {
    cli.fail("--mode incremental is RRR's: --verifier " +
             rrr::toString(args.verifier.choice.verifier) + " decides in batch");
  }
  return args;
}

// rrr_slam_offline's --decision-stream format (decision_stream.h): the replay has no scans, so
// `scan` is the number of nodes arrived, and `stamp` the seconds since the replay started.
void writeDecisionStream(const std::string& path, const std::vector<rrr::ReplayEvent>& events,
                         const rrr::VerificationGraph& graph) {
  tools::DecisionStream stream;
  for (const rrr::ReplayEvent& e : events) {
    const rrr::LoopCandidate& c = graph.candidate(e.candidate);
    stream.add(static_cast<std::size_t>(e.nodes), e.nodes, e.seconds, e.final,
               {e.candidate, graph.nodeIds()[static_cast<std::size_t>(c.from)],
                graph.nodeIds()[static_cast<std::size_t>(c.to)], e.cluster, e.verdict, e.previous,
                e.reason});
  }
  stream.write(path);
}

rrr::ProgressFunction terminalProgress(bool quiet) {
  if (quiet || !isatty(STDERR_FILENO)) return {};
  return [](const char* stage, int done, int total) {
    std::fprintf(stderr, "\r[%s] %d/%d   ", stage, done, total);
    if (done == total) std::fprintf(stderr, "\n");
  };
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parseArguments(argc, argv);
  if (const auto warning = core::blasKernelWarning())
    std::fprintf(stderr, "warning: %s\n", warning->c_str());
  try {
    core::GraphReadOptions read_options;
    read_options.allow_disconnected = true;  // sessions without an accepted link stay apart
    core::PoseGraph graph = core::readPoseGraph(args.input, read_options);
    rrr::VerificationGraph verification(graph, args.params.optimizer);

    std::vector<rrr::Verdict> verdicts;
    std::vector<int> cluster_of;
    rrr::RrrSummary summary;
    std::vector<double> latencies;
    std::vector<std::string> reasons;
    std::vector<rrr::ReplayEvent> events;
    if (args.incremental) {
      summary = rrr::runIncrementalRrr(verification, args.params, verdicts, cluster_of,
                                       terminalProgress(args.quiet), &latencies, &reasons,
                                       args.decision_stream.empty() ? nullptr : &events);
    } else {
      rrr::VerifierDecisions decided = rrr::decideBatch(verification, args.verifier.choice,
                                                        args.params, terminalProgress(args.quiet));
      verdicts = std::move(decided.verdicts);
      cluster_of = std::move(decided.cluster_of);
      reasons = std::move(decided.reasons);
      summary = decided.summary;
    }

    std::printf("input          %s: %zu nodes, %zu edges\n", args.input.c_str(), graph.numNodes(),
                graph.numEdges());
    std::printf("mode           %s\n", args.incremental ? "incremental" : "batch");
    if (args.verifier.choice.verifier != rrr::Verifier::kRrr) {
      std::printf("verifier       %s\n", rrr::toString(args.verifier.choice.verifier).c_str());
    }
    std::printf("candidates     %d\n", summary.candidates);
    std::printf("clusters       %d (gap %d nodes)\n", summary.clusters, summary.cluster_gap);
    std::printf("accepted       %d\n", summary.accepted);
    std::printf("rejected       %d\n", summary.rejected);
    std::printf("optimizations  %d\n", summary.optimizations);
    std::printf("time           %.3f s\n", summary.time_sec);
    if (args.profile) {
      if (summary.steps.empty()) {
        std::printf("profile        none: --verifier %s has no named steps\n",
                    rrr::toString(args.verifier.choice.verifier).c_str());
      } else {
        std::printf("profile\n%s", rrr::formatStepProfile(summary.steps, summary.time_sec).c_str());
      }
    }
    if (!latencies.empty()) {
      std::sort(latencies.begin(), latencies.end());
      auto percentile = [&](double q) {
        return latencies[std::min(latencies.size() - 1,
                                  static_cast<std::size_t>(q * latencies.size()))];
      };
      // The online target is a p99 under 50 ms; the updates over it say how far off a run is.
      const auto over_50_ms =
          std::count_if(latencies.begin(), latencies.end(), [](double sec) { return sec > 0.05; });
      std::printf(
          "latency        p50 %.2f ms, p99 %.2f ms, max %.2f ms per update, %ld over 50 ms\n",
          1e3 * percentile(0.5), 1e3 * percentile(0.99), 1e3 * latencies.back(),
          static_cast<long>(over_50_ms));
    }

    if (!args.decisions.empty()) {
      std::vector<rrr::DecisionRow> rows;
      for (int k = 0; k < verification.numCandidates(); ++k) {
        const auto& edge = graph.edge(verification.candidate(k).edge);
        const auto i = static_cast<std::size_t>(k);
        rows.push_back({edge.from, edge.to, cluster_of[i], verdicts[i], reasons[i]});
      }
      rrr::writeDecisions(args.decisions, rows);
      std::printf("decisions      %s\n", args.decisions.c_str());
    }
    if (!args.decision_stream.empty()) {
      writeDecisionStream(args.decision_stream, events, verification);
      std::printf("decision stream %s (%zu rows)\n", args.decision_stream.c_str(), events.size());
    }
    if (!args.output.empty()) {
      core::PoseGraph optimized;
      const auto& poses = verification.optimizer().poses();
      const auto& ids = verification.nodeIds();
      for (std::size_t n = 0; n < ids.size(); ++n) optimized.addNode(ids[n], poses[n]);
      for (std::size_t k = 0; k < graph.numEdges(); ++k) {
        const auto& e = graph.edge(k);
        const bool keep = e.kind == core::EdgeKind::kOdometry ||
                          verification.optimizer().isActive(static_cast<int>(k));
        if (keep)
          optimized.addEdge(e.from, e.to, graph.measurement(k), graph.information(k), e.kind);
      }
      for (const core::DenseFactor& f : graph.denseFactors()) optimized.addDenseFactor(f);
      core::writePoseGraph(optimized, args.output);
      std::printf("output         %s\n", args.output.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_offline: " << e.what() << "\n";
    return 1;
  }
}
