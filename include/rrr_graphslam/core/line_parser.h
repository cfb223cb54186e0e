#pragma once
// The fields of one line of a text format (g2o, TORO, CARMEN), read with errors that name the file,
// the line, the field and what is wrong with it.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::core {

/// Whitespace-separated fields; views into `line`.
std::vector<std::string_view> splitFields(std::string_view line);

/// Reads fields[k] (fields[0] is the tag) of the line `reader` returned last; every failure throws
/// InputError(file, line, "field k of TAG ('text') is not ...").
class LineParser {
 public:
  LineParser(const LineReader& reader, std::string_view tag,
             const std::vector<std::string_view>& fields)
      : reader_(reader), tag_(tag), fields_(fields) {}

  std::size_t size() const { return fields_.size(); }
  /// Exactly `count` fields after the tag.
  void expectCount(std::size_t count) const;
  /// At least `count` fields after the tag.
  void expectAtLeast(std::size_t count, const std::string& why) const;
  /// A non-negative integer.
  std::uint64_t unsignedInteger(std::size_t k, const char* what) const;
  /// A finite number.
  double number(std::size_t k) const;
  Pose2 pose(std::size_t first) const {
    return {number(first), number(first + 1), number(first + 2)};
  }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  std::string field(std::size_t k) const;

  const LineReader& reader_;
  std::string_view tag_;
  const std::vector<std::string_view>& fields_;
};

}  // namespace rrr_graphslam::core
