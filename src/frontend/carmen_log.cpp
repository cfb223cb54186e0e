#include "rrr_graphslam/frontend/carmen_log.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/core/line_parser.h"
#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::frontend {
namespace {

using core::LineParser;

// Fields of the line after field k.
std::size_t fieldsAfter(const LineParser& parse, std::size_t k) {
  return parse.size() > k + 1 ? parse.size() - k - 1 : 0;
}

// The count in field k of items that follow it, which must leave room for at least `after` more
// fields (compared without overflow: a count near 2^64 is an error, not a wrapped index).
std::size_t itemCount(const LineParser& parse, std::size_t k, const char* what, std::size_t after) {
  const std::uint64_t n = parse.unsignedInteger(k, what);
  const std::size_t available = fieldsAfter(parse, k);
  if (available < after || n > available - after) {
    parse.fail(std::string(what) + " of " + std::to_string(n) + " (field " + std::to_string(k) +
               ") leaves " + std::to_string(available < after ? 0 : available - after) +
               " fields for the items: the line holds " + std::to_string(parse.size() - 1) +
               " fields after the tag");
  }
  return static_cast<std::size_t>(n);
}

// The scan's reading count in field k, followed by its readings and `after` more fields.
std::size_t readingCount(const LineParser& parse, std::size_t k, std::size_t after) {
  const std::size_t n = itemCount(parse, k, "a reading count", after);
  if (n < 2) parse.fail("a scan needs at least 2 readings, found " + std::to_string(n));
  return n;
}

std::vector<float> readRanges(const LineParser& parse, std::size_t first, std::size_t n) {
  std::vector<float> ranges(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = parse.number(first + i);
    if (r < 0.0) parse.fail("reading " + std::to_string(i) + " is negative");
    // Ranges are single precision: beyond it a reading would become infinite.
    if (r > std::numeric_limits<float>::max()) {
      parse.fail("reading " + std::to_string(i) + " (field " + std::to_string(first + i) +
                 ") is beyond the single-precision range");
    }
    ranges[i] = static_cast<float>(r);
  }
  return ranges;
}

// FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname logger_timestamp
LaserRecord parseFlaser(const LineParser& parse) {
  LaserRecord r;
  const std::size_t n = readingCount(parse, 1, 9);
  // Exactly: a count one off would read every field after the readings one place off.
  parse.expectCount(n + 10);
  r.ranges = readRanges(parse, 2, n);
  r.laser_pose = parse.pose(2 + n);
  r.odom_pose = parse.pose(5 + n);
  r.timestamp = parse.number(8 + n);
  r.angle_min = -M_PI / 2.0;
  r.angle_increment = flaserIncrement(n);
  r.max_range = std::nan("");  // the log's largest reading, set once the whole log is read
  return r;
}

// ROBOTLASER1 type start fov resolution max_range accuracy remission_mode n r1..rn nrem rem..
//   laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety side_safety
//   turn_axis ipc_timestamp ipc_hostname logger_timestamp
LaserRecord parseRobotLaser(const LineParser& parse) {
  LaserRecord r;
  r.angle_min = parse.number(2);
  r.angle_increment = parse.number(4);
  r.max_range = parse.number(5);
  if (r.angle_increment <= 0.0) parse.fail("the angular resolution (field 4) must be positive");
  if (r.max_range <= 0.0) parse.fail("the maximum range (field 5) must be positive");
  const std::size_t n = readingCount(parse, 8, 1 + 14);
  r.ranges = readRanges(parse, 9, n);
  const std::size_t k_rem = 9 + n;
  const std::size_t n_rem = itemCount(parse, k_rem, "a remission count", 14);
  const std::size_t k = k_rem + 1 + n_rem;
  // Exactly: laser pose, robot pose, tv, rv, forward and side safety, turn axis, timestamps, host.
  parse.expectCount(k + 13);
  r.laser_pose = parse.pose(k);
  r.odom_pose = parse.pose(k + 3);
  r.timestamp = parse.number(k + 11);
  return r;
}

}  // namespace

double flaserIncrement(std::size_t n) {
  return n % 2 == 0 ? M_PI / static_cast<double>(n) : M_PI / static_cast<double>(n - 1);
}

CarmenLog readCarmenLog(const std::string& path) {
  CarmenLog log;
  log.path = path;
  core::LineReader reader(path);
  std::string line;
  while (reader.next(line)) {
    const auto fields = core::splitFields(line);
    if (fields.empty()) continue;
    const std::string_view tag = fields[0];
    if (tag != "FLASER" && tag != "ROBOTLASER1") continue;
    const LineParser parse(reader, tag, fields);
    LaserRecord r = tag == "FLASER" ? parseFlaser(parse) : parseRobotLaser(parse);
    r.laser_pose.z() = core::normalizeAngle(r.laser_pose.z());
    r.odom_pose.z() = core::normalizeAngle(r.odom_pose.z());
    r.line = reader.lineNumber();
    log.scans.push_back(std::move(r));
  }
  if (log.scans.empty()) throw core::InputError(path, 0, "no FLASER or ROBOTLASER1 line");
  // FLASER states no maximum: the log's largest FLASER reading is its "no return" value.
  float flaser_max = 0.0F;
  for (const LaserRecord& r : log.scans) {
    if (std::isnan(r.max_range)) {
      flaser_max = std::max(flaser_max, *std::max_element(r.ranges.begin(), r.ranges.end()));
    }
  }
  for (LaserRecord& r : log.scans) {
    if (std::isnan(r.max_range)) r.max_range = flaser_max;
  }
  return log;
}

}  // namespace rrr_graphslam::frontend
