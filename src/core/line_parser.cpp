#include "rrr_graphslam/core/line_parser.h"

#include <cctype>
#include <charconv>
#include <cmath>

#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::core {

std::vector<std::string_view> splitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
  return fields;
}

std::string LineParser::field(std::size_t k) const {
  return "field " + std::to_string(k) + " of " + std::string(tag_) + " ('" +
         std::string(fields_[k]) + "')";
}

void LineParser::expectCount(std::size_t count) const {
  if (fields_.size() - 1 != count) {
    fail(std::string(tag_) + " expects " + std::to_string(count) + " fields after the tag, found " +
         std::to_string(fields_.size() - 1));
  }
}

void LineParser::expectAtLeast(std::size_t count, const std::string& why) const {
  if (fields_.size() - 1 < count) {
    fail(std::string(tag_) + " " + why + " needs at least " + std::to_string(count) +
         " fields after the tag, found " + std::to_string(fields_.size() - 1));
  }
}

std::uint64_t LineParser::unsignedInteger(std::size_t k, const char* what) const {
  if (k >= fields_.size()) fail(std::string(tag_) + " ends before field " + std::to_string(k));
  const std::string_view f = fields_[k];
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), value);
  if (ec != std::errc() || end != f.data() + f.size()) fail(field(k) + " is not " + what);
  return value;
}

double LineParser::number(std::size_t k) const {
  if (k >= fields_.size()) fail(std::string(tag_) + " ends before field " + std::to_string(k));
  const std::string_view f = fields_[k];
  double value = 0.0;
  const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), value);
  if ((ec != std::errc() && ec != std::errc::result_out_of_range) || end != f.data() + f.size()) {
    fail(field(k) + " is not a number");
  }
  if (!std::isfinite(value) || ec == std::errc::result_out_of_range) {
    fail(field(k) + " is not finite");
  }
  return value;
}

void LineParser::fail(const std::string& what) const {
  throw InputError(reader_.path(), reader_.lineNumber(), what);
}

}  // namespace rrr_graphslam::core
