#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::core {
namespace {

std::string formatMessage(const std::string& source, std::size_t line, const std::string& what) {
  if (line == 0) return source + ": " + what;
  return source + ":" + std::to_string(line) + ": " + what;
}

}  // namespace

InputError::InputError(const std::string& source, std::size_t line, const std::string& what)
    : std::runtime_error(formatMessage(source, line, what)),
      source_(source),
      line_(line),
      reason_(what) {}

}  // namespace rrr_graphslam::core
