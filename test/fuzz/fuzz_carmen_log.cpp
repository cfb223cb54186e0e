// libFuzzer target of frontend::readCarmenLog: FLASER and ROBOTLASER1 lines among any others,
// plain or gzip.
//
// A bad input must throw InputError. Besides crashes and sanitizer errors it checks what
// carmen_log.h promises for an accepted log: every number finite, at least 2 readings, none
// negative, a positive resolution, angles wrapped, lines in order, FLASER's maximum range the
// log's largest FLASER reading. For a plain-text input it also reads each accepted line again,
// field by field as the format comments in carmen_log.cpp list them, and checks that the reader
// took every value from the right field and that the line holds every field its counts call for
// (the remission count included).

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_input.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/carmen_log.h"

namespace rrr_graphslam::fuzz {
namespace {

using frontend::LaserRecord;

// The lines as LineReader returns them: split at '\n', trailing '\r' removed; lines[0] is line 1.
std::vector<std::string_view> linesOf(std::string_view text) {
  std::vector<std::string_view> lines;
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    std::string_view line = text.substr(0, end);
    while (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    text.remove_prefix(std::min(end + 1, text.size()));
  }
  return lines;
}

std::vector<std::string_view> fieldsOf(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t i = 0;
  while (i < line.size()) {
    if (std::isspace(static_cast<unsigned char>(line[i]))) {
      ++i;
      continue;
    }
    std::size_t end = i;
    while (end < line.size() && !std::isspace(static_cast<unsigned char>(line[end]))) ++end;
    fields.push_back(line.substr(i, end - i));
    i = end;
  }
  return fields;
}

// Field k as a number; NaN when it is missing or not one (never equal to what the reader kept).
double numberAt(const std::vector<std::string_view>& fields, std::size_t k) {
  if (k >= fields.size()) return std::nan("");
  double value = std::nan("");
  std::from_chars(fields[k].data(), fields[k].data() + fields[k].size(), value);
  return value;
}

// Field k as a count, capped at the number of fields (a larger count cannot fit in the line).
std::size_t countAt(const std::vector<std::string_view>& fields, std::size_t k) {
  std::uint64_t value = UINT64_MAX;
  if (k < fields.size()) {
    std::from_chars(fields[k].data(), fields[k].data() + fields[k].size(), value);
  }
  return static_cast<std::size_t>(std::min<std::uint64_t>(value, fields.size()));
}

bool samePose(const core::Pose2& pose, const std::vector<std::string_view>& fields,
              std::size_t first) {
  return pose.x() == numberAt(fields, first) && pose.y() == numberAt(fields, first + 1) &&
         pose.z() == core::normalizeAngle(numberAt(fields, first + 2));
}

void checkRecord(const LaserRecord& r) {
  RRR_FUZZ_CHECK(r.ranges.size() >= 2, "a scan has at least 2 readings");
  for (float range : r.ranges) {
    RRR_FUZZ_CHECK(std::isfinite(range), "every reading is finite");
    RRR_FUZZ_CHECK(range >= 0.0F, "no reading is negative");
  }
  RRR_FUZZ_CHECK(std::isfinite(r.timestamp) && std::isfinite(r.angle_min),
                 "timestamp and first angle are finite");
  RRR_FUZZ_CHECK(std::isfinite(r.angle_increment) && r.angle_increment > 0.0,
                 "the resolution is finite and positive");
  for (const core::Pose2* pose : {&r.laser_pose, &r.odom_pose}) {
    RRR_FUZZ_CHECK(pose->allFinite(), "poses are finite");
    RRR_FUZZ_CHECK(pose->z() > -M_PI && pose->z() <= M_PI, "pose angles are in (-pi, pi]");
  }
}

// The reader's record against the fields of the line it came from.
void checkAgainstLine(const LaserRecord& r, const std::vector<std::string_view>& f) {
  RRR_FUZZ_CHECK(!f.empty() && (f[0] == "FLASER" || f[0] == "ROBOTLASER1"),
                 "a record comes from a FLASER or ROBOTLASER1 line");
  const std::size_t n = r.ranges.size();
  const bool flaser = f[0] == "FLASER";
  // FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp [ipc_hostname logger_ts]
  // ROBOTLASER1 type start fov resolution max_range accuracy mode n r1..rn nrem rem1..remN
  //   laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fsafe ssafe turn_axis
  //   ipc_timestamp ipc_hostname logger_timestamp
  const std::size_t first_range = flaser ? 2 : 9;
  RRR_FUZZ_CHECK(countAt(f, first_range - 1) == n, "as many readings as the line's count");
  for (std::size_t i = 0; i < n; ++i) {
    RRR_FUZZ_CHECK(r.ranges[i] == static_cast<float>(numberAt(f, first_range + i)),
                   "reading i is field first_range + i");
  }
  std::size_t pose_field = 2 + n;
  std::size_t timestamp_field = 8 + n;
  std::size_t needed = 9 + n;  // fields with the tag, up to the timestamp
  if (!flaser) {
    pose_field = 10 + n + countAt(f, 9 + n);
    timestamp_field = pose_field + 11;
    needed = pose_field + 14;  // the reader wants the hostname and logger timestamp too
    RRR_FUZZ_CHECK(r.angle_min == numberAt(f, 2) && r.angle_increment == numberAt(f, 4) &&
                       r.max_range == numberAt(f, 5),
                   "ROBOTLASER1 start angle, resolution and maximum range from fields 2, 4, 5");
  } else {
    RRR_FUZZ_CHECK(r.angle_increment == frontend::flaserIncrement(n), "FLASER's resolution");
  }
  RRR_FUZZ_CHECK(f.size() >= needed, "the line holds every field its counts call for");
  RRR_FUZZ_CHECK(samePose(r.laser_pose, f, pose_field), "laser pose from its fields");
  RRR_FUZZ_CHECK(samePose(r.odom_pose, f, pose_field + 3), "robot pose from its fields");
  RRR_FUZZ_CHECK(r.timestamp == numberAt(f, timestamp_field), "ipc_timestamp from its field");
}

}  // namespace
}  // namespace rrr_graphslam::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace frontend = rrr_graphslam::frontend;
  namespace fuzz = rrr_graphslam::fuzz;
  const std::string& path = fuzz::writeInput(data, size);
  frontend::CarmenLog log;
  try {
    log = frontend::readCarmenLog(path);
  } catch (const rrr_graphslam::core::InputError&) {
    return 0;  // a bad input, reported as the reader promises
  } catch (const std::exception& e) {
    fuzz::unexpectedException(e);
  }

  RRR_FUZZ_CHECK(!log.scans.empty(), "an accepted log has scans");
  std::size_t previous_line = 0;
  for (const frontend::LaserRecord& r : log.scans) {
    fuzz::checkRecord(r);
    RRR_FUZZ_CHECK(r.line > previous_line, "records in line order");
    previous_line = r.line;
  }
  // After every reading was checked: FLASER's maximum is one of them.
  for (const frontend::LaserRecord& r : log.scans) {
    RRR_FUZZ_CHECK(std::isfinite(r.max_range) && r.max_range >= 0.0, "the maximum range is finite");
  }
  if (size >= 2 && data[0] == 0x1f && data[1] == 0x8b) return 0;  // gzip: zlib's lines, not ours

  const auto lines = fuzz::linesOf(std::string_view(reinterpret_cast<const char*>(data), size));
  float flaser_max = 0.0F;
  std::vector<bool> is_flaser;
  for (const frontend::LaserRecord& r : log.scans) {
    RRR_FUZZ_CHECK(r.line <= lines.size(), "a record's line is in the file");
    const auto fields = fuzz::fieldsOf(lines[r.line - 1]);
    fuzz::checkAgainstLine(r, fields);
    is_flaser.push_back(fields[0] == "FLASER");
    if (is_flaser.back()) {
      flaser_max = std::max(flaser_max, *std::max_element(r.ranges.begin(), r.ranges.end()));
    }
  }
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    RRR_FUZZ_CHECK(!is_flaser[k] || log.scans[k].max_range == flaser_max,
                   "FLASER's maximum range is the log's largest FLASER reading");
  }
  return 0;
}
