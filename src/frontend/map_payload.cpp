#include "rrr_graphslam/frontend/map_payload.h"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace rrr_graphslam::frontend {
namespace {

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

int toInt(std::int64_t v, const char* what) {
  if (v < -1 || v > 2'000'000'000) {
    throw std::invalid_argument(std::string(what) + " " + std::to_string(v) + " is out of range");
  }
  return static_cast<int>(v);
}

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

}  // namespace

std::string encodeMapPayload(const MapSnapshot& map) {
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

MapSnapshot decodeMapPayload(const std::vector<std::uint8_t>& bytes, std::uint32_t version) {
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
      const auto newest = version >= 6 ? LoopSource::kRivalSearch : LoopSource::kExternal;
      if (source > static_cast<std::uint8_t>(newest)) {
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

}  // namespace rrr_graphslam::frontend
