#include "rrr_graphslam/frontend/map_file.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <type_traits>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/plausible_pose.h"

namespace rrr_graphslam::frontend {
namespace {

constexpr char kMagic[8] = {'R', 'R', 'R', 'M', 'A', 'P', '\n', '\0'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 8 + 8 + 4;
// Payloads are held in memory whole; beyond this a file is refused rather than allocated.
constexpr std::uint64_t kMaxPayloadBytes = std::uint64_t{1} << 31;
// A remembered patch is a tile of a session's view: 10 m and its margins.
constexpr double kMaxPatchExtent = 1e3;

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "map files are little-endian; a big-endian build needs byte swaps in Writer/Reader");

// Little-endian records. Every length read is checked against the bytes left before anything is
// allocated: MRPT's own deserializers allocate from lengths in the data first (a 4 GiB label or a
// billion readings in a damaged scan), which a map file read from a robot's disk cannot allow.
class Writer {
 public:
  template <class T>
  void put(T value) {
    static_assert(std::is_arithmetic_v<T>);
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    bytes_.append(bytes, sizeof(T));
  }
  void put(const std::string& text) {
    put<std::uint64_t>(text.size());
    bytes_ += text;
  }
  void put(const core::Pose2& p) {
    put(p.x());
    put(p.y());
    put(p.z());
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class Reader {
 public:
  explicit Reader(const std::vector<std::uint8_t>& bytes) : bytes_(bytes) {}
  template <class T>
  T get() {
    static_assert(std::is_arithmetic_v<T>);
    need(sizeof(T), "a value");
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  double finite() {
    const double v = get<double>();
    if (!std::isfinite(v)) throw std::invalid_argument("a value is not finite");
    return v;
  }
  std::string text() {
    const std::size_t n = count(1, "a string");
    std::string s(reinterpret_cast<const char*>(bytes_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  core::Pose2 pose() {
    const double x = get<double>(), y = get<double>(), z = get<double>();
    return {x, y, z};
  }
  /// `n` raw bytes (checked against the bytes left).
  std::vector<std::uint8_t> raw(std::size_t n, const char* what) {
    need(n, what);
    std::vector<std::uint8_t> out(bytes_.begin() + static_cast<std::ptrdiff_t>(pos_),
                                  bytes_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return out;
  }
  /// A count of items of at least `item_bytes` each, checked against the bytes left.
  std::size_t count(std::size_t item_bytes, const char* what) {
    const auto n = get<std::uint64_t>();
    if (n > (bytes_.size() - pos_) / item_bytes) {
      throw std::invalid_argument(std::string(what) + " count " + std::to_string(n) +
                                  " exceeds the " + std::to_string(bytes_.size() - pos_) +
                                  " bytes left");
    }
    return static_cast<std::size_t>(n);
  }
  void expectEnd() const {
    if (pos_ != bytes_.size()) {
      throw std::invalid_argument(std::to_string(bytes_.size() - pos_) + " bytes after the map");
    }
  }
  /// Throws unless `n` bytes are left.
  void need(std::size_t n, const char* what) const {
    if (bytes_.size() - pos_ < n) {
      throw std::invalid_argument(std::string("ends inside ") + what + " at byte " +
                                  std::to_string(pos_));
    }
  }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::size_t pos_ = 0;
};

// A scan as the grids use it: its geometry, readings and their validity.
void putScan(Writer& out, const mrpt::obs::CObservation2DRangeScan& scan) {
  out.put<std::int64_t>(scan.timestamp.time_since_epoch().count());
  out.put(scan.aperture);
  out.put<std::uint8_t>(scan.rightToLeft ? 1 : 0);
  out.put(scan.maxRange);
  for (double v : {scan.sensorPose.x(), scan.sensorPose.y(), scan.sensorPose.z(),
                   scan.sensorPose.yaw(), scan.sensorPose.pitch(), scan.sensorPose.roll()}) {
    out.put(v);
  }
  out.put(scan.stdError);
  out.put(scan.beamAperture);
  out.put(scan.deltaPitch);
  out.put<std::uint64_t>(scan.getScanSize());
  for (std::size_t i = 0; i < scan.getScanSize(); ++i) {
    out.put(scan.getScanRange(i));
    out.put<std::uint8_t>(scan.getScanRangeValidity(i) ? 1 : 0);
  }
}

std::shared_ptr<const mrpt::obs::CObservation2DRangeScan> getScan(Reader& in) {
  auto scan = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
  scan->timestamp = mrpt::Clock::time_point(mrpt::Clock::duration(in.get<std::int64_t>()));
  scan->aperture = in.get<float>();
  const auto right_to_left = in.get<std::uint8_t>();
  if (right_to_left > 1) throw std::invalid_argument("a scan's direction byte is not 0 or 1");
  scan->rightToLeft = right_to_left == 1;
  scan->maxRange = in.get<float>();
  double pose[6];
  for (double& v : pose) v = in.finite();
  scan->sensorPose = mrpt::poses::CPose3D(pose[0], pose[1], pose[2], pose[3], pose[4], pose[5]);
  scan->stdError = in.get<float>();
  scan->beamAperture = in.get<float>();
  scan->deltaPitch = in.get<double>();
  if (!std::isfinite(scan->aperture) || !std::isfinite(scan->maxRange) ||
      !std::isfinite(scan->stdError) || !std::isfinite(scan->beamAperture) ||
      !std::isfinite(scan->deltaPitch)) {
    throw std::invalid_argument("a scan's aperture, range, error or pitch is not finite");
  }
  const std::size_t n = in.count(sizeof(float) + 1, "a scan's reading");
  scan->resizeScan(n);
  for (std::size_t i = 0; i < n; ++i) {
    scan->setScanRange(i, in.get<float>());
    const auto valid = in.get<std::uint8_t>();
    if (valid > 1) throw std::invalid_argument("a reading's validity byte is not 0 or 1");
    scan->setScanRangeValidity(i, valid == 1);
  }
  return scan;
}

std::string encodePayload(const MapSnapshot& map) {
  Writer out;
  out.put<std::uint64_t>(map.params.size());
  for (const auto& [name, value] : map.params) {
    out.put(name);
    out.put(value);
  }
  out.put<std::uint64_t>(map.sessions.size());
  for (const auto& s : map.sessions) {
    out.put(s.name);
    out.put(s.start_time);
    out.put<std::int64_t>(s.first_node);
    if (map.format_version >= 3) out.put<std::int64_t>(s.number);
  }
  out.put<std::uint64_t>(map.nodes.size());
  for (const auto& n : map.nodes) {
    out.put<std::int64_t>(n.session);
    out.put(n.timestamp);
    out.put(n.local_pose);
    out.put(n.map_pose);
    putScan(out, *n.scan);
  }
  out.put<std::uint64_t>(map.edges.size());
  for (const auto& e : map.edges) {
    out.put<std::int64_t>(e.from);
    out.put<std::int64_t>(e.to);
    out.put(static_cast<std::uint8_t>(e.kind));
    out.put(e.measurement);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out.put(e.information(r, c));
    }
    out.put(static_cast<std::uint8_t>(e.verdict));
    out.put<std::int64_t>(e.cluster);
    out.put(e.reason);
    if (map.format_version >= 4) out.put(static_cast<std::uint8_t>(e.source));
  }
  out.put<std::uint64_t>(map.submaps.size());
  for (const auto& s : map.submaps) {
    out.put<std::int64_t>(s.first_node);
    out.put<std::int64_t>(s.last_node);
  }
  if (map.format_version >= 2) {
    out.put<std::int64_t>(map.lifelong.trimmed_submaps);
    out.put<std::int64_t>(map.lifelong.marginalized_nodes);
  }
  if (map.format_version >= 3) {
    out.put<std::uint64_t>(map.memory.size());
    for (const RememberedCells& patch : map.memory) {
      out.put<std::int64_t>(patch.session);
      out.put<std::int64_t>(patch.anchor_node);
      out.put(patch.origin);
      out.put(patch.resolution_m);
      out.put<std::int64_t>(patch.width);
      out.put<std::int64_t>(patch.height);
      out.put<std::uint64_t>(patch.cells->size());
      for (std::uint8_t v : *patch.cells) out.put(v);
    }
  }
  if (map.format_version >= 5) {
    out.put<std::uint64_t>(map.dense_factors.size());
    for (const core::DenseFactor& f : map.dense_factors) {
      out.put<std::uint64_t>(f.nodes.size());
      for (auto id : f.nodes) out.put<std::int64_t>(static_cast<std::int64_t>(id));
      for (const core::Pose2& y : f.measurements) out.put(y);
      for (Eigen::Index r = 0; r < f.mean.size(); ++r) out.put(f.mean(r));
      for (Eigen::Index r = 0; r < f.information.rows(); ++r) {  // upper triangle, row by row
        for (Eigen::Index c = r; c < f.information.cols(); ++c) out.put(f.information(r, c));
      }
      out.put(f.chi2_offset);
    }
  }
  return out.bytes();
}

int toInt(std::int64_t v, const char* what) {
  if (v < -1 || v > 2'000'000'000) {
    throw std::invalid_argument(std::string(what) + " " + std::to_string(v) + " is out of range");
  }
  return static_cast<int>(v);
}

MapSnapshot decodePayload(const std::vector<std::uint8_t>& bytes, std::uint32_t version) {
  MapSnapshot map;
  map.format_version = version;
  Reader in(bytes);
  // Items are appended as they decode (never allocated from a count), and each count is checked
  // against its record's smallest size.
  const std::size_t params = in.count(16, "parameter");
  for (std::size_t k = 0; k < params; ++k) {
    std::string name = in.text();
    std::string value = in.text();
    map.params.emplace_back(std::move(name), std::move(value));
  }
  const std::size_t sessions = in.count(24, "session");
  for (std::size_t k = 0; k < sessions; ++k) {
    MapSnapshot::Session& s = map.sessions.emplace_back();
    s.name = in.text();
    s.start_time = in.get<double>();
    s.first_node = toInt(in.get<std::int64_t>(), "session first node");
    s.number = version >= 3 ? toInt(in.get<std::int64_t>(), "session number") : static_cast<int>(k);
  }
  const std::size_t nodes = in.count(153, "node");
  for (std::size_t k = 0; k < nodes; ++k) {
    MapSnapshot::Node& n = map.nodes.emplace_back();
    n.session = toInt(in.get<std::int64_t>(), "node session");
    n.timestamp = in.get<double>();
    n.local_pose = in.pose();
    n.map_pose = in.pose();
    n.scan = getScan(in);
  }
  const std::size_t edges = in.count(130, "edge");
  for (std::size_t k = 0; k < edges; ++k) {
    MapSnapshot::Edge& e = map.edges.emplace_back();
    e.from = toInt(in.get<std::int64_t>(), "edge from");
    e.to = toInt(in.get<std::int64_t>(), "edge to");
    const auto kind = in.get<std::uint8_t>();
    if (kind > 2) throw std::invalid_argument("edge kind " + std::to_string(kind) + " is unknown");
    e.kind = static_cast<MapSnapshot::EdgeKind>(kind);
    e.measurement = in.pose();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) e.information(r, c) = in.get<double>();
    }
    const auto verdict = in.get<std::uint8_t>();
    if (verdict > 2)
      throw std::invalid_argument("verdict " + std::to_string(verdict) + " is unknown");
    e.verdict = static_cast<rrr::Verdict>(verdict);
    e.cluster = toInt(in.get<std::int64_t>(), "edge cluster");
    e.reason = in.text();
    if (version >= 4) {
      const auto source = in.get<std::uint8_t>();
      if (source > 4) {
        throw std::invalid_argument("loop source " + std::to_string(source) + " is unknown");
      }
      e.source = static_cast<LoopSource>(source);
    }
  }
  const std::size_t submaps = in.count(16, "submap");
  for (std::size_t k = 0; k < submaps; ++k) {
    MapSnapshot::Submap& s = map.submaps.emplace_back();
    s.first_node = toInt(in.get<std::int64_t>(), "submap first node");
    s.last_node = toInt(in.get<std::int64_t>(), "submap last node");
  }
  if (version >= 2) {
    map.lifelong.trimmed_submaps = toInt(in.get<std::int64_t>(), "trimmed submap count");
    map.lifelong.marginalized_nodes = toInt(in.get<std::int64_t>(), "marginalized node count");
  }
  if (version >= 3) {
    const std::size_t patches = in.count(72, "remembered patch");
    for (std::size_t k = 0; k < patches; ++k) {
      RememberedCells& patch = map.memory.emplace_back();
      patch.session = toInt(in.get<std::int64_t>(), "remembered patch session");
      patch.anchor_node = toInt(in.get<std::int64_t>(), "remembered patch anchor node");
      patch.origin = in.pose();
      patch.resolution_m = in.get<double>();
      patch.width = toInt(in.get<std::int64_t>(), "remembered patch width");
      patch.height = toInt(in.get<std::int64_t>(), "remembered patch height");
      const std::size_t cells = in.count(1, "remembered patch cell");
      patch.cells = std::make_shared<const std::vector<std::uint8_t>>(
          in.raw(cells, "remembered patch cells"));
    }
  }
  if (version >= 5) {
    // The smallest factor: two nodes, one measurement, 3 means, 6 information entries, offset.
    const std::size_t factors = in.count(8 + 2 * 8 + 3 * 8 + 3 * 8 + 6 * 8 + 8, "dense factor");
    for (std::size_t k = 0; k < factors; ++k) {
      core::DenseFactor& f = map.dense_factors.emplace_back();
      // Per node at least its id, a measurement and 3 means (the root has neither, but the
      // information's entries more than make up for it).
      const std::size_t n = in.count(8 + 3 * 8 + 3 * 8, "dense factor node");
      if (n < 2 || n > kMaxDenseFactorNodes) {
        throw std::invalid_argument("a dense factor over " + std::to_string(n) + " nodes (2 to " +
                                    std::to_string(kMaxDenseFactorNodes) + " are read)");
      }
      for (std::size_t i = 0; i < n; ++i) {
        const int id = toInt(in.get<std::int64_t>(), "dense factor node");
        if (id < 0) throw std::invalid_argument("a dense factor node is negative");
        f.nodes.push_back(static_cast<mrpt::graphs::TNodeID>(id));
      }
      for (std::size_t i = 0; i + 1 < n; ++i) f.measurements.push_back(in.pose());
      const auto rows = static_cast<Eigen::Index>(3 * (n - 1));
      f.mean.resize(rows);
      for (Eigen::Index r = 0; r < rows; ++r) f.mean(r) = in.get<double>();
      const std::size_t entries =
          static_cast<std::size_t>(rows) * (static_cast<std::size_t>(rows) + 1) / 2;
      in.need(entries * sizeof(double), "a dense factor's information");  // before allocating
      f.information.resize(rows, rows);
      for (Eigen::Index r = 0; r < rows; ++r) {
        for (Eigen::Index c = r; c < rows; ++c) {
          f.information(r, c) = f.information(c, r) = in.get<double>();
        }
      }
      f.chi2_offset = in.get<double>();
    }
  }
  in.expectEnd();
  return map;
}

template <class T>
void putRaw(std::string& out, T value) {
  for (std::size_t k = 0; k < sizeof(T); ++k) {
    out.push_back(static_cast<char>((static_cast<std::uint64_t>(value) >> (8 * k)) & 0xff));
  }
}

template <class T>
T getRaw(const std::string& in, std::size_t offset) {
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < sizeof(T); ++k) {
    v |= static_cast<std::uint64_t>(static_cast<unsigned char>(in[offset + k])) << (8 * k);
  }
  return static_cast<T>(v);
}

}  // namespace

void MapSnapshot::check() const {
  const int n = static_cast<int>(nodes.size());
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (format_version == 0 || format_version > kMapFormatVersion) {
    fail("format version " + std::to_string(format_version) +
         " is not one this build writes (1 to " + std::to_string(kMapFormatVersion) + ")");
  }
  if (lifelong.trimmed_submaps < 0 || lifelong.marginalized_nodes < 0) {
    fail("the lifelong counts are negative");
  }
  if (format_version < 2 && (lifelong.trimmed_submaps > 0 || lifelong.marginalized_nodes > 0)) {
    fail("format version 1 cannot hold the lifelong counts");
  }
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    const int first = sessions[k].first_node;
    const int next = k + 1 < sessions.size() ? sessions[k + 1].first_node : n;
    if (!std::isfinite(sessions[k].start_time)) {
      fail("session " + std::to_string(k) + "'s start time is not finite");
    }
    if (first < 0 || first >= next || next > n) {
      fail("session " + std::to_string(k) + " starts at node " + std::to_string(first) +
           ", not before the next session or the end");
    }
    const int number = sessions[k].number;
    if (number < 0 || number > 1'000'000'000 || (k > 0 && number <= sessions[k - 1].number)) {
      fail("session " + std::to_string(k) + " has number " + std::to_string(number) +
           ", not above the session before's (numbers grow over the map's life)");
    }
    if (format_version < 3 && number != static_cast<int>(k)) {
      fail("session " + std::to_string(k) + " has number " + std::to_string(number) +
           ", which format version " + std::to_string(format_version) +
           " cannot hold (it numbers sessions in order)");
    }
  }
  if (format_version < 3 && !memory.empty()) {
    fail("format version " + std::to_string(format_version) +
         " cannot hold the memory of trimmed submaps");
  }
  for (std::size_t k = 0; k < memory.size(); ++k) {
    const RememberedCells& patch = memory[k];
    try {
      patch.check(n);
      if (patch.origin.head<2>().cwiseAbs().maxCoeff() > kMaxCoordinate ||
          std::max(patch.width, patch.height) * patch.resolution_m > kMaxPatchExtent) {
        fail("it lies beyond 1e6 m of its anchor or spans more than 1 km");
      }
      if (!sessions.empty() && patch.session > sessions.back().number) {
        fail("its session " + std::to_string(patch.session) + " is newer than the map's newest");
      }
    } catch (const std::invalid_argument& e) {
      fail("remembered patch " + std::to_string(k) + ": " + e.what());
    }
  }
  if (n > 0 && (sessions.empty() || sessions.front().first_node != 0)) {
    fail("the first session does not start at node 0");
  }
  for (int k = 0; k < n; ++k) {
    const Node& node = nodes[static_cast<std::size_t>(k)];
    if (node.session < 0 || node.session >= static_cast<int>(sessions.size()) ||
        sessions[static_cast<std::size_t>(node.session)].first_node > k ||
        (node.session + 1 < static_cast<int>(sessions.size()) &&
         sessions[static_cast<std::size_t>(node.session) + 1].first_node <= k)) {
      fail("node " + std::to_string(k) + " names session " + std::to_string(node.session) +
           ", which does not hold it");
    }
    // The limits local SLAM holds live scans to: the grids rebuilt from these must stay sane.
    auto plausible = [](const core::Pose2& p) {
      return p.allFinite() && p.head<2>().cwiseAbs().maxCoeff() <= kMaxCoordinate;
    };
    if (!plausible(node.local_pose) || !plausible(node.map_pose) ||
        !std::isfinite(node.timestamp)) {
      fail("node " + std::to_string(k) + " has a pose beyond 1e6 m or a value that is not finite");
    }
    if (node.scan == nullptr) fail("node " + std::to_string(k) + " has no scan");
    const auto& scan = *node.scan;
    const auto& laser = scan.sensorPose;
    if (std::hypot(laser.x(), laser.y()) > kMaxLaserOffset ||
        std::abs(laser.z()) > kMaxLaserOffset || !(scan.maxRange > 0.0F) ||
        !std::isfinite(scan.maxRange) || !std::isfinite(scan.aperture)) {
      fail("node " + std::to_string(k) +
           "'s scan has its laser more than 100 m from the robot, or a maximum range or aperture "
           "that is not finite and positive");
    }
    for (std::size_t i = 0; i < scan.getScanSize(); ++i) {
      const float r = scan.getScanRange(i);
      if (scan.getScanRangeValidity(i) && !(r >= 0.0F && r <= scan.maxRange)) {
        fail("node " + std::to_string(k) + "'s scan has a valid reading outside [0, maxRange]");
      }
    }
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = edges[k];
    if (e.from < 0 || e.to < 0 || e.from >= n || e.to >= n || e.from == e.to) {
      fail("edge " + std::to_string(k) + " joins " + std::to_string(e.from) + " and " +
           std::to_string(e.to) + ", not two of the " + std::to_string(n) + " nodes");
    }
    if (e.kind == EdgeKind::kOdometry &&
        (std::abs(e.from - e.to) != 1 || nodes[static_cast<std::size_t>(e.from)].session !=
                                             nodes[static_cast<std::size_t>(e.to)].session)) {
      fail("odometry edge " + std::to_string(k) + " does not join consecutive nodes of a session");
    }
    if (e.kind == EdgeKind::kMarginal && format_version < 2) {
      fail("edge " + std::to_string(k) + " is marginal, which format version 1 cannot hold");
    }
    if (e.source != LoopSource::kUnknown && e.kind != EdgeKind::kLoopCandidate) {
      fail("edge " + std::to_string(k) + " has a loop source but is no loop candidate");
    }
    if (e.source != LoopSource::kUnknown && format_version < 4) {
      fail("edge " + std::to_string(k) + " has a loop source, which format version " +
           std::to_string(format_version) + " cannot hold");
    }
    if (!e.measurement.allFinite() || !e.information.allFinite()) {
      fail("edge " + std::to_string(k) + " has a measurement or information that is not finite");
    }
  }
  if (format_version < 5 && !dense_factors.empty()) {
    fail("format version " + std::to_string(format_version) + " cannot hold dense factors");
  }
  for (std::size_t k = 0; k < dense_factors.size(); ++k) {
    const core::DenseFactor& f = dense_factors[k];
    if (f.nodes.size() > kMaxDenseFactorNodes) {  // before the factorization below
      fail("dense factor " + std::to_string(k) + " holds " + std::to_string(f.nodes.size()) +
           " nodes, more than the " + std::to_string(kMaxDenseFactorNodes) + " a map file holds");
    }
    for (auto id : f.nodes) {
      if (id >= static_cast<std::size_t>(n)) {
        fail("dense factor " + std::to_string(k) + " holds node " + std::to_string(id) +
             ", not one of the " + std::to_string(n) + " nodes");
      }
    }
    const std::string problem = core::denseFactorProblem(f);
    if (!problem.empty()) fail("dense factor " + std::to_string(k) + ": " + problem);
  }
  for (std::size_t k = 0; k < submaps.size(); ++k) {
    const Submap& s = submaps[k];
    if (s.first_node < 0 || s.first_node > s.last_node || s.last_node >= n ||
        nodes[static_cast<std::size_t>(s.first_node)].session !=
            nodes[static_cast<std::size_t>(s.last_node)].session) {
      fail("submap " + std::to_string(k) + " spans nodes " + std::to_string(s.first_node) + " to " +
           std::to_string(s.last_node) + ", not nodes of one session");
    }
  }
}

std::string toString(LoopSource source) { return core::choiceName(source); }

void writeMapFile(const MapSnapshot& map, const std::string& path) {
  map.check();
  const std::string payload = encodePayload(map);
  if (payload.size() >= kMaxPayloadBytes) {
    throw std::runtime_error(path + ": the map is too large for the format (" +
                             std::to_string(payload.size()) + " bytes)");
  }
  uLongf packed_size = compressBound(static_cast<uLong>(payload.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
                reinterpret_cast<const Bytef*>(payload.data()), static_cast<uLong>(payload.size()),
                Z_DEFAULT_COMPRESSION) != Z_OK) {
    throw std::runtime_error(path + ": compression failed");
  }
  packed.resize(packed_size);
  std::string header(kMagic, sizeof kMagic);
  putRaw<std::uint32_t>(header, map.format_version);
  putRaw<std::uint64_t>(header, payload.size());
  putRaw<std::uint64_t>(header, packed.size());
  putRaw<std::uint32_t>(
      header, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(packed.data()),
                                               static_cast<uInt>(packed.size()))));
  core::writeFileAtomically(path, [&](std::ostream& out) { out << header << packed; });
}

MapSnapshot readMapFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw core::InputError(path, 0, "cannot open the map file");
  auto fail = [&](const std::string& what) { throw core::InputError(path, 0, what); };
  // The header first: a file that is no map (a bag given by mistake) is not read whole.
  std::string data(kHeaderBytes, '\0');
  file.read(data.data(), static_cast<std::streamsize>(kHeaderBytes));
  if (static_cast<std::size_t>(file.gcount()) < kHeaderBytes ||
      std::memcmp(data.data(), kMagic, sizeof kMagic) != 0) {
    fail("not an rrr_graphslam map file (no RRRMAP header)");
  }
  {
    // The body is allocated only once the file is known to hold what the header states.
    const auto stated = getRaw<std::uint64_t>(data, 20);
    file.seekg(0, std::ios::end);
    const auto end = static_cast<std::uint64_t>(file.tellg());
    if (!file || end < kHeaderBytes || stated != end - kHeaderBytes) {
      fail("truncated or padded: the header says " + std::to_string(stated) +
           " compressed bytes, the file holds " +
           std::to_string(end >= kHeaderBytes ? end - kHeaderBytes : 0));
    }
    if (stated > compressBound(static_cast<uLong>(kMaxPayloadBytes))) {
      fail("the header states " + std::to_string(stated) + " compressed bytes: too many");
    }
    file.seekg(static_cast<std::streamoff>(kHeaderBytes));
    data.resize(kHeaderBytes + static_cast<std::size_t>(stated));
    file.read(data.data() + kHeaderBytes, static_cast<std::streamsize>(stated));
    if (static_cast<std::uint64_t>(file.gcount()) != stated) fail("read error");
  }
  const auto version = getRaw<std::uint32_t>(data, 8);
  if (version == 0 || version > kMapFormatVersion) {
    fail("format version " + std::to_string(version) + " is " +
         (version == 0
              ? "invalid"
              : "newer than this build reads (" + std::to_string(kMapFormatVersion) + ")"));
  }
  const auto payload_size = getRaw<std::uint64_t>(data, 12);
  const auto packed_size = getRaw<std::uint64_t>(data, 20);
  const auto crc = getRaw<std::uint32_t>(data, 28);
  if (packed_size != data.size() - kHeaderBytes) {
    fail("truncated or padded: the header says " + std::to_string(packed_size) +
         " compressed bytes, the file holds " + std::to_string(data.size() - kHeaderBytes));
  }
  const auto* packed = reinterpret_cast<const Bytef*>(data.data() + kHeaderBytes);
  if (crc32(0, packed, static_cast<uInt>(packed_size)) != crc) fail("checksum mismatch: corrupted");
  // The CRC held, so the size is what the writer wrote; bound it anyway (deflate's ratio stays
  // below 1032:1).
  if (payload_size > 1040 * (packed_size + 1) || payload_size >= kMaxPayloadBytes) {
    fail("payload size " + std::to_string(payload_size) + " is implausible");
  }
  std::vector<std::uint8_t> payload(payload_size);
  uLongf unpacked = static_cast<uLongf>(payload_size);
  if (uncompress(payload.data(), &unpacked, packed, static_cast<uLong>(packed_size)) != Z_OK ||
      unpacked != payload_size) {
    fail("the compressed payload does not decompress to its stated size");
  }
  try {
    MapSnapshot map = decodePayload(payload, version);
    map.check();
    return map;
  } catch (const std::exception& e) {
    fail(std::string("malformed payload: ") + e.what());
  }
  return {};
}

core::EdgeKind toCoreKind(MapSnapshot::EdgeKind kind) {
  switch (kind) {
    case MapSnapshot::EdgeKind::kOdometry:
      return core::EdgeKind::kOdometry;
    case MapSnapshot::EdgeKind::kMarginal:
      return core::EdgeKind::kMarginal;
    case MapSnapshot::EdgeKind::kLoopCandidate:
      break;
  }
  return core::EdgeKind::kLoopCandidate;
}

namespace {

core::PoseGraph poseGraphOf(const MapSnapshot& map, bool trusted_only) {
  core::PoseGraph graph;
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    graph.addNode(static_cast<core::PoseGraph::NodeId>(k), map.nodes[k].map_pose);
  }
  for (const auto& e : map.edges) {
    if (trusted_only && e.kind == MapSnapshot::EdgeKind::kLoopCandidate &&
        e.verdict != rrr::Verdict::kAccepted) {
      continue;
    }
    graph.addEdge(static_cast<core::PoseGraph::NodeId>(e.from),
                  static_cast<core::PoseGraph::NodeId>(e.to), e.measurement, e.information,
                  toCoreKind(e.kind));
  }
  for (const core::DenseFactor& f : map.dense_factors) graph.addDenseFactor(f);
  return graph;
}

}  // namespace

core::PoseGraph mapPoseGraph(const MapSnapshot& map) { return poseGraphOf(map, false); }

core::PoseGraph trustedPoseGraph(const MapSnapshot& map) { return poseGraphOf(map, true); }

}  // namespace rrr_graphslam::frontend
