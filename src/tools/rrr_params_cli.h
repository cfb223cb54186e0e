#pragma once
// RRR's parameters on a tool's command line: --preset paper|default, and every RrrParams field
// (rrr_params.h) as --name-with-dashes VALUE (booleans: true or false), with the same ranges and
// messages as the ROS parameters.

#include <sstream>
#include <stdexcept>
#include <string>

#include "params_cli.h"
#include "rrr_graphslam/rrr/rrr_params.h"

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

}  // namespace rrr_graphslam::tools
