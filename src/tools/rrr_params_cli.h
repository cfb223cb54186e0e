#pragma once
// RRR's parameters on a tool's command line: --preset paper|default, and every RrrParams field
// (rrr_params.h) as --name-with-dashes VALUE (booleans: true or false), with the same ranges and
// messages as the ROS parameters.

#include <sstream>
#include <stdexcept>
#include <string>

#include "params_cli.h"
#include "rrr_graphslam/rrr/rrr_params.h"
#include "rrr_graphslam/rrr/verifier_choice.h"

namespace rrr_graphslam::tools {

/// Applies --preset NAME wherever it stands, so that the other flags override it.
inline void applyPresetArgument(const CommandLine& cli, int argc, char** argv,
                                rrr::RrrParams& params) {
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) != "--preset") continue;
    const std::string name = cli.value(i, "--preset");
    try {
      rrr::applyPreset(name, params);
    } catch (const std::invalid_argument& e) {
      cli.fail(e.what());
    }
  }
}

/// If argv[i] is --preset or an RrrParams flag, reads its value (advancing i) and returns true.
inline bool readRrrParam(const CommandLine& cli, int& i, char** argv, rrr::RrrParams& params) {
  const std::string a = argv[i];
  if (a == "--preset") {
    cli.value(i, a);  // applied by applyPresetArgument
    return true;
  }
  return readTableParam(cli, i, argv, params, [](auto& p, auto&& f) { rrr::forEachParam(p, f); });
}

/// One usage line per RrrParams flag, with its default (the tool's own defaults if given).
inline std::string rrrParamsUsage(const rrr::RrrParams& defaults = {}) {
  std::ostringstream out;
  out << "  --preset paper|default  paper: the published RRR, every addition off; default: all "
         "on\n";
  out << tableUsage(defaults, [](auto& p, auto&& f) { rrr::forEachParam(p, f); });
  return out.str();
}

/// --verifier rrr|pcm|scgp|gnc with --gnc-loss tls|gm and --scgp-ratio R, as read so far.
struct VerifierArguments {
  rrr::VerifierChoice choice;
  bool gnc_loss_given = false;
  bool scgp_ratio_given = false;
};

/// If argv[i] is one of the verifier flags, reads its value (advancing i) and returns true.
inline bool readVerifierArgument(const CommandLine& cli, int& i, char** argv,
                                 VerifierArguments& args) {
  const std::string a = argv[i];
  try {
    if (a == "--verifier") {
      args.choice.verifier = rrr::parseVerifier(cli.value(i, a));
    } else if (a == "--gnc-loss") {
      args.gnc_loss_given = true;
      args.choice.gnc_loss = rrr::parseGncLoss(cli.value(i, a));
    } else if (a == "--scgp-ratio") {
      args.scgp_ratio_given = true;
      args.choice.scgp_ratio = cli.number(a, cli.value(i, a), 1.0, 1e9);
    } else {
      return false;
    }
  } catch (const std::invalid_argument& e) {
    cli.fail(a + ": " + e.what());
  }
  return true;
}

/// Refuses a setting of a verifier other than the chosen one.
inline void checkVerifierArguments(const CommandLine& cli, const VerifierArguments& args) {
  if (args.gnc_loss_given && args.choice.verifier != rrr::Verifier::kGnc) {
    cli.fail("--gnc-loss needs --verifier gnc");
  }
  if (args.scgp_ratio_given && args.choice.verifier != rrr::Verifier::kScgp) {
    cli.fail("--scgp-ratio needs --verifier scgp");
  }
}

/// The usage lines of the verifier flags; `online`: for a tool that decides while it maps.
inline std::string verifierUsage(bool online) {
  std::string text =
      "  --verifier       rrr (default); pcm (pairwise consistency maximization), scgp\n"
      "                   (Olson's single-cluster graph partitioning per time cluster) or gnc\n"
      "                   (graduated non-convexity) to compare; pcm and gnc use --alpha for\n"
      "                   their chi-square bound, scgp --cluster-gap for its clusters\n";
  text += online ? "                   pcm, scgp and gnc decide the closed clusters' candidates "
                   "again\n                   whenever a time cluster closes: their cost grows "
                   "with the run\n"
                 : "                   pcm, scgp and gnc decide in batch only\n";
  text +=
      "  --gnc-loss       tls (truncated least squares, default) or gm (Geman-McClure)\n"
      "  --scgp-ratio     scgp's local uniqueness: l1/l2 at least this (default 2)\n";
  return text;
}

}  // namespace rrr_graphslam::tools
