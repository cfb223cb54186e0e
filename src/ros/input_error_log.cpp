#include "rrr_graphslam/ros/input_error_log.h"

#include <cstdio>

namespace rrr_graphslam::ros_adapter {

std::string quoteShort(const std::string& text, std::size_t max_chars) {
  std::string out;
  for (std::size_t i = 0; i < text.size() && out.size() < max_chars; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
    if (out.size() >= max_chars && i + 1 < text.size()) {
      out += "... (" + std::to_string(text.size()) + " bytes)";
      break;
    }
  }
  return out;
}

std::optional<std::string> InputErrorLog::line(const std::string& topic, const std::string& what,
                                               double now_sec) {
  std::string field = what.substr(0, std::min<std::size_t>(what.find(' '), 64));
  if (!field.empty() && field.back() == ':') field.pop_back();
  const auto [it, first] = kinds_.try_emplace(topic + " " + field);
  Kind& kind = it->second;
  if (!first && now_sec - kind.last_sec < period_sec_) {
    ++kind.suppressed;
    return std::nullopt;
  }
  std::string text = topic + ": " + quoteShort(what, max_chars_);
  if (kind.suppressed > 0) {
    text += " (" + std::to_string(kind.suppressed) + " more like it since the last one)";
  }
  kind.last_sec = now_sec;
  kind.suppressed = 0;
  return text;
}

}  // namespace rrr_graphslam::ros_adapter
