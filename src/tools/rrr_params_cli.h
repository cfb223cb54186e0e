#pragma once
// RRR's parameters on a tool's command line: --preset paper|default, and every RrrParams field
// (rrr_params.h) as --name-with-dashes VALUE (booleans: true or false), with the same ranges and
// messages as the ROS parameters.

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "command_line.h"
#include "rrr_graphslam/rrr/rrr_params.h"

namespace rrr_graphslam::tools {

inline std::string flagOf(const char* name) {
  std::string flag = std::string("--") + name;
  for (char& c : flag) c = c == '_' ? '-' : c;
  return flag;
}

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
  bool found = false;
  rrr::forEachParam(params, [&](const rrr::ParamInfo& info, auto& field) {
    if (found || a != flagOf(info.name)) return;
    found = true;
    const std::string text = cli.value(i, a);
    using T = std::decay_t<decltype(field)>;
    if constexpr (std::is_same_v<T, bool>) {
      if (text != "true" && text != "false")
        cli.fail(a + " must be true or false, not '" + text + "'");
      field = text == "true";
    } else {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end == text.c_str() || *end != '\0')
        cli.fail(a + " must be a number, not '" + text + "'");
      if (!(v >= info.low && v <= info.high)) cli.fail(rrr::outOfRangeMessage(info, text));
      if (std::is_integral_v<T> && v != std::floor(v))
        cli.fail(a + " must be an integer, not '" + text + "'");
      field = static_cast<T>(v);
    }
  });
  return found;
}

/// One usage line per RrrParams flag, with its default.
inline std::string rrrParamsUsage() {
  std::ostringstream out;
  out << "  --preset paper|default  paper: the published RRR, every addition off; default: all "
         "on\n";
  const rrr::RrrParams defaults;
  rrr::forEachParam(defaults, [&](const rrr::ParamInfo& info, const auto& value) {
    std::ostringstream v;
    if constexpr (std::is_same_v<std::decay_t<decltype(value)>, bool>) {
      v << (value ? "true" : "false");
    } else {
      v << value;
    }
    std::string flag = "  " + flagOf(info.name) + " V";
    flag.resize(std::max<std::size_t>(flag.size() + 1, 36), ' ');
    out << flag << info.doc << " (default " << v.str() << ")\n";
  });
  return out.str();
}

}  // namespace rrr_graphslam::tools
