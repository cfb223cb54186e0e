#include "rrr_graphslam/sim/yaml_fields.h"

#include <cmath>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <sstream>

#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::sim {
namespace {

using mrpt::containers::yaml;

std::size_t lineOf(const yaml& node) {
  return static_cast<std::size_t>(node.node().marks.line) + 1;
}

std::string describe(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A scalar's text as a finite number; false for anything else ("1.5m", "nan", "").
bool parseNumber(const std::string& text, double& v) {
  char* end = nullptr;
  v = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(v);
}

// A sequence of exactly `count` finite numbers; `error` says what is wrong otherwise.
std::vector<double> numberList(const yaml& value, std::size_t count, std::string& error) {
  std::vector<double> out;
  if (!value.isSequence() || value.asSequence().size() != count) {
    error = "must be a list of " + std::to_string(count) + " numbers, e.g. [" +
            (count == 2 ? "1.0, 2.0" : "1.0, 2.0, 0.0") + "]";
    return out;
  }
  for (const yaml::node_t& item : value.asSequence()) {
    const yaml element(item);
    double v = 0.0;
    std::string text;
    if (element.isScalar()) {
      try {
        text = element.as<std::string>();
      } catch (const std::exception&) {
      }
    }
    if (!parseNumber(text, v)) {
      error =
          "element " + std::to_string(out.size() + 1) + " is not a finite number: '" + text + "'";
      return out;
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace

YamlEntry::YamlEntry(const std::string& path, const yaml& node, std::string label)
    : path_(path), node_(node), label_(std::move(label)) {
  if (!node_.isMap()) {
    throw core::InputError(
        path_, line(),
        (label_.empty() ? "the file" : label_) + " is not a map of 'key: value' fields");
  }
}

std::size_t YamlEntry::line(const std::string& key) const {
  if (key.empty() || !node_.has(key)) return lineOf(node_);
  return lineOf(node_[key]);
}

void YamlEntry::fail(const std::string& key, const std::string& what) const {
  std::string message = label_.empty() ? "" : label_ + ": ";
  if (!key.empty()) message += "'" + key + "' ";
  throw core::InputError(path_, line(key), message + what);
}

yaml YamlEntry::field(const std::string& key) const {
  if (!node_.has(key)) fail(key, "is missing");
  return yaml(node_[key].node());
}

std::string YamlEntry::scalar(const std::string& key) const {
  const yaml value = field(key);
  if (!value.isScalar()) fail(key, "must be a single value, not a list or map");
  try {
    return value.as<std::string>();
  } catch (const std::exception&) {
    fail(key, "is not readable as text");
  }
}

std::string YamlEntry::string(const std::string& key) const {
  const std::string text = scalar(key);
  if (text.empty()) fail(key, "is empty");
  return text;
}

double YamlEntry::number(const std::string& key, double low, double high) const {
  const std::string text = scalar(key);
  double v = 0.0;
  if (!parseNumber(text, v)) fail(key, "is not a finite number: '" + text + "'");
  if (v < low || v > high) {
    fail(key, "= " + text + " is out of range: must be in [" + describe(low) + ", " +
                  describe(high) + "]");
  }
  return v;
}

double YamlEntry::numberOr(const std::string& key, double fallback, double low, double high) const {
  return has(key) ? number(key, low, high) : fallback;
}

long YamlEntry::integer(const std::string& key, long low, long high) const {
  const double v = number(key, static_cast<double>(low), static_cast<double>(high));
  if (v != std::floor(v)) fail(key, "must be an integer, not " + describe(v));
  return static_cast<long>(v);
}

std::vector<double> YamlEntry::numbers(const std::string& key, std::size_t count) const {
  std::string error;
  std::vector<double> out = numberList(field(key), count, error);
  if (!error.empty()) fail(key, error);
  return out;
}

std::vector<YamlEntry::Point> YamlEntry::points(const std::string& key,
                                                const std::string& item_label) const {
  const yaml value = field(key);
  if (!value.isSequence()) fail(key, "must be a list of points, e.g. [[1.0, 2.0], [3.0, 4.0]]");
  std::vector<Point> out;
  for (const yaml::node_t& item : value.asSequence()) {
    std::string error;
    const std::vector<double> xy = numberList(yaml(item), 2, error);
    const std::string label = item_label + " " + std::to_string(out.size() + 1);
    const std::size_t line = static_cast<std::size_t>(item.marks.line) + 1;
    if (!error.empty()) {
      throw core::InputError(path_, line,
                             (label_.empty() ? "" : label_ + ": ") + label + " " + error);
    }
    out.push_back({Eigen::Vector2d(xy[0], xy[1]), line});
  }
  return out;
}

std::vector<YamlEntry> YamlEntry::entries(const std::string& key,
                                          const std::string& item_label) const {
  const yaml value = field(key);
  if (!value.isSequence()) fail(key, "must be a list of entries ('- key: value' items)");
  std::vector<YamlEntry> out;
  for (const yaml::node_t& item : value.asSequence()) {
    out.emplace_back(path_, yaml(item), item_label + " " + std::to_string(out.size() + 1));
  }
  return out;
}

void YamlEntry::expectOnly(std::initializer_list<const char*> known) const {
  for (const auto& [key_node, value] : node_.asMap()) {
    const std::string key = yaml(key_node).as<std::string>();
    bool found = false;
    for (const char* k : known) found = found || key == k;
    if (!found) {
      std::string list;
      for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      fail(key, "is not a known field (known: " + list + ")");
    }
  }
}

YamlDocument::YamlDocument(const std::string& path) : path_(path) {
  if (!std::ifstream(path)) throw core::InputError(path, 0, "cannot open the file");
  try {
    doc_ = yaml::FromFile(path);
  } catch (const std::exception& e) {
    // MRPT's message carries its own context lines; keep only its first line.
    std::string what = e.what();
    const std::size_t eol = what.find('\n');
    throw core::InputError(path, 0, "not readable as YAML: " + what.substr(0, eol));
  }
}

YamlEntry YamlDocument::root(const std::string& what) const {
  if (!doc_.isMap()) throw core::InputError(path_, 0, "is not " + what + " (a YAML map)");
  return YamlEntry(path_, doc_, "");
}

}  // namespace rrr_graphslam::sim
