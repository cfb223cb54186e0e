#pragma once
// Errors about the node's input, as a robot in trouble sends them: thousands a second, with fields
// megabytes long. Each (topic, field) kind is logged at most once per period, the next line
// saying how many were suppressed; every line quotes at most a short, printable prefix of what it
// reports. Plain C++ (the caller logs the line), so it is tested without ROS.

#include <cstddef>
#include <map>
#include <optional>
#include <string>

namespace rrr_graphslam::ros_adapter {

/// `text` cut to `max_chars` characters, bytes outside printable ASCII written as \xNN, and a
/// cut saying how long the text was.
std::string quoteShort(const std::string& text, std::size_t max_chars);

class InputErrorLog {
 public:
  explicit InputErrorLog(double period_sec = 1.0, std::size_t max_chars = 300)
      : period_sec_(period_sec), max_chars_(max_chars) {}

  /// The line to log for error `what` (its first word names the field) on `topic` at `now_sec`,
  /// or nullopt while that kind was logged less than a period ago (it is counted, and the next
  /// line of its kind says how many were suppressed).
  std::optional<std::string> line(const std::string& topic, const std::string& what,
                                  double now_sec);

 private:
  struct Kind {
    double last_sec = 0.0;
    std::size_t suppressed = 0;
  };
  double period_sec_;
  std::size_t max_chars_;
  std::map<std::string, Kind> kinds_;
};

}  // namespace rrr_graphslam::ros_adapter
