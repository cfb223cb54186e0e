#pragma once
// A parameter table (core/param_info.h) on a tool's command line: every field as
// --name-with-dashes VALUE, with the table's ranges and messages. Values: numbers; true or false;
// an enum's choice name; three comma-separated numbers for a vector.

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "command_line.h"
#include "rrr_graphslam/core/param_info.h"

namespace rrr_graphslam::tools {

inline std::string flagOf(const char* name) {
  std::string flag = std::string("--") + name;
  for (char& c : flag) c = c == '_' ? '-' : c;
  return flag;
}

/// `text` as a number, or a usage error naming `flag`.
inline double parseNumber(const CommandLine& cli, const std::string& flag,
                          const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') cli.fail(flag + " must be a number, not '" + text + "'");
  return v;
}

/// Sets `field` from the text of flag `flag` (the table's entry `info`), or fails with the
/// table's message.
template <class T>
void parseParam(const CommandLine& cli, const std::string& flag, const core::ParamInfo& info,
                const std::string& text, T& field) {
  if constexpr (std::is_same_v<T, bool>) {
    field = cli.boolean(flag, text);
  } else if constexpr (std::is_enum_v<T>) {
    if (!core::parseChoice(text, field))
      cli.fail(core::notAChoiceMessage(info, text, core::choiceNames<T>()));
  } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
    std::vector<std::string> parts(1);
    for (char c : text) {
      if (c == ',') {
        parts.emplace_back();
      } else {
        parts.back() += c;
      }
    }
    if (parts.size() != 3)
      cli.fail(flag + " must be three comma-separated numbers, not '" + text + "'");
    Eigen::Vector3d v;
    for (int j = 0; j < 3; ++j) v[j] = parseNumber(cli, flag, parts[static_cast<std::size_t>(j)]);
    for (int j = 0; j < 3; ++j) {
      if (!(v[j] >= info.low && v[j] <= info.high)) cli.fail(core::outOfRangeMessage(info, text));
    }
    field = v;
  } else {
    const double v = parseNumber(cli, flag, text);
    if (!(v >= info.low && v <= info.high)) cli.fail(core::outOfRangeMessage(info, text));
    if (std::is_integral_v<T> && v != std::floor(v))
      cli.fail(flag + " must be an integer, not '" + text + "'");
    field = static_cast<T>(v);
  }
}

/// If argv[i] is the flag of a field of `params` (forEach(params, f) visits the table), reads its
/// value (advancing i) and returns true.
template <class Params, class ForEach>
bool readTableParam(const CommandLine& cli, int& i, char** argv, Params& params,
                    ForEach&& forEach) {
  const std::string a = argv[i];
  bool found = false;
  forEach(params, [&](const core::ParamInfo& info, auto& field) {
    if (found || a != flagOf(info.name)) return;
    found = true;
    parseParam(cli, a, info, cli.value(i, a), field);
  });
  return found;
}

/// One usage line per field of the table, with its default.
template <class Params, class ForEach>
std::string tableUsage(const Params& defaults, ForEach&& forEach) {
  std::ostringstream out;
  forEach(defaults, [&](const core::ParamInfo& info, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    std::string flag =
        "  " + flagOf(info.name) + (std::is_same_v<T, Eigen::Vector3d> ? " X,Y,Z" : " V");
    flag.resize(std::max<std::size_t>(flag.size() + 1, 36), ' ');
    out << flag << info.doc << " (default " << core::formatParam(value) << ")\n";
  });
  return out.str();
}

}  // namespace rrr_graphslam::tools
