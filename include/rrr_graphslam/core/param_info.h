#pragma once
// A parameter table's entry: every tunable struct (RrrParams, LaserSlamParams) lists its fields
// once, with a name, a closed range and a doc line, in a forEach...(params, f) function; the
// command-line tools (--name-with-dashes), the ROS nodelet (~name), config/rrr_graphslam.yaml and
// validate() all follow that list, so a bad value gets the same message from every entry point.
//
// A field is a double, int, bool, an enum with choices() (named values), or an Eigen::Vector3d
// (three numbers, each in the range).

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace rrr_graphslam::core {

struct ParamInfo {
  const char* name;  ///< ROS parameter and YAML key; the command-line flag is --name-with-dashes
  double low;        ///< closed range of valid values (of each entry of a vector)
  double high;
  const char* doc;
};

/// "NAME = VALUE is out of range: must be in [LOW, HIGH]".
std::string outOfRangeMessage(const ParamInfo& info, const std::string& value);

/// "A, B or C".
std::string choiceList(const std::vector<std::string>& names);

/// "NAME must be A, B or C, not 'VALUE'".
std::string notAChoiceMessage(const ParamInfo& info, const std::string& value,
                              const std::vector<std::string>& names);

template <class T>
using Choices = std::vector<std::pair<T, const char*>>;

/// The names of an enum parameter's values (found by ADL: `choices(E{})` must exist).
template <class E>
std::vector<std::string> choiceNames() {
  std::vector<std::string> names;
  for (const auto& [value, name] : choices(E{})) names.emplace_back(name);
  return names;
}

template <class E>
std::string choiceName(E value) {
  for (const auto& [v, name] : choices(E{})) {
    if (v == value) return name;
  }
  return "?";
}

/// Sets `value` to the choice named `text`; false if there is none.
template <class E>
bool parseChoice(const std::string& text, E& value) {
  for (const auto& [v, name] : choices(E{})) {
    if (text == name) {
      value = v;
      return true;
    }
  }
  return false;
}

/// The choice named `text`; std::invalid_argument "WHAT 'TEXT' is not A, B or C" if none is.
template <class E>
E parseChoiceOrThrow(const std::string& text, const std::string& what) {
  E value{};
  if (!parseChoice(text, value)) {
    throw std::invalid_argument(what + " '" + text + "' is not " + choiceList(choiceNames<E>()));
  }
  return value;
}

/// A value as the YAML and the messages write it.
template <class T>
std::string formatParam(const T& value) {
  std::ostringstream out;
  out.precision(12);
  if constexpr (std::is_same_v<T, bool>) {
    out << (value ? "true" : "false");
  } else if constexpr (std::is_enum_v<T>) {
    out << choiceName(value);
  } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
    out << '[' << value[0] << ", " << value[1] << ", " << value[2] << ']';
  } else {
    out << value;
  }
  return out.str();
}

/// Throws std::invalid_argument with outOfRangeMessage if `value` (each entry of a vector) is
/// outside the range or NaN; bools and enums are always in range.
template <class T>
void checkRange(const ParamInfo& info, const T& value) {
  if constexpr (std::is_same_v<T, bool> || std::is_enum_v<T>) {
    return;
  } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
    for (int k = 0; k < 3; ++k) {
      if (!(value[k] >= info.low && value[k] <= info.high))
        throw std::invalid_argument(outOfRangeMessage(info, formatParam(value)));
    }
  } else {
    const auto v = static_cast<double>(value);
    if (!(v >= info.low && v <= info.high))
      throw std::invalid_argument(outOfRangeMessage(info, formatParam(value)));
  }
}

}  // namespace rrr_graphslam::core
