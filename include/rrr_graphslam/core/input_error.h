#pragma once
// The one exception type for bad input: it always names where the input came from
// (a file and line, or a topic and field) and what is wrong with it.

#include <cstddef>
#include <stdexcept>
#include <string>

namespace rrr_graphslam::core {

class InputError : public std::runtime_error {
 public:
  /// `source` is a file path or a topic; `line` is 0 when there is no line (e.g. a message).
  InputError(const std::string& source, std::size_t line, const std::string& what);

  const std::string& source() const { return source_; }
  std::size_t line() const { return line_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string source_;
  std::size_t line_;
  std::string reason_;
};

}  // namespace rrr_graphslam::core
