#pragma once
// Typed fields of a YAML map read with MRPT's parser (mrpt::containers::yaml), with errors that
// name the file, the line, the entry and the field: every failure throws
// core::InputError(file, line, "ENTRY: FIELD ...").

#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

#include <mrpt/containers/yaml.h>
#include <Eigen/Core>

namespace rrr_graphslam::sim {

class YamlEntry {
 public:
  /// `node` must be a map; `label` names it in messages (e.g. "change 3"), empty for the root.
  YamlEntry(const std::string& path, const mrpt::containers::yaml& node, std::string label);

  bool has(const std::string& key) const { return node_.has(key); }
  std::string string(const std::string& key) const;
  /// A finite number in [low, high].
  double number(const std::string& key, double low, double high) const;
  double numberOr(const std::string& key, double fallback, double low, double high) const;
  /// An integer in [low, high].
  long integer(const std::string& key, long low, long high) const;
  /// A sequence of exactly `count` finite numbers, e.g. [x, y].
  std::vector<double> numbers(const std::string& key, std::size_t count) const;
  struct Point {
    Eigen::Vector2d xy;
    std::size_t line;  ///< 1-based
  };
  /// A sequence of [x, y] pairs; an error names the bad one as "`item_label` k".
  std::vector<Point> points(const std::string& key, const std::string& item_label) const;
  /// The maps of a sequence, each labelled "`item_label` k" (k from 1).
  std::vector<YamlEntry> entries(const std::string& key, const std::string& item_label) const;
  /// Fails on a key not in `known` (a misspelt field would otherwise be ignored silently).
  void expectOnly(std::initializer_list<const char*> known) const;

  /// 1-based line of `key`'s value, or of the entry itself for an empty key.
  std::size_t line(const std::string& key = "") const;
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  /// A copy of `key`'s value (its marks included); fails when the key is missing.
  mrpt::containers::yaml field(const std::string& key) const;
  std::string scalar(const std::string& key) const;

  std::string path_;
  mrpt::containers::yaml node_;
  std::string label_;
};

/// A YAML file parsed at once: a syntax error throws InputError naming the file (and MRPT's line).
class YamlDocument {
 public:
  explicit YamlDocument(const std::string& path);
  /// The root map; `what` names the expected content in the error for anything else.
  YamlEntry root(const std::string& what) const;

 private:
  std::string path_;
  mrpt::containers::yaml doc_;
};

}  // namespace rrr_graphslam::sim
