#include "rrr_graphslam/frontend/map_file.h"

#include <zlib.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <mrpt/serialization/CArchive.h>
#include <mrpt/serialization/archiveFrom_std_vector.h>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::frontend {
namespace {

constexpr char kMagic[8] = {'R', 'R', 'R', 'M', 'A', 'P', '\n', '\0'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 8 + 8 + 4;

using Archive = mrpt::serialization::CArchive;

void putPose(Archive& out, const core::Pose2& p) { out << p.x() << p.y() << p.z(); }
core::Pose2 getPose(Archive& in) {
  double x = 0, y = 0, z = 0;
  in >> x >> y >> z;
  return {x, y, z};
}

// A count read from the payload, which cannot exceed the payload's bytes (every item takes at
// least one): a corrupted or hostile count fails here instead of allocating.
std::size_t getCount(Archive& in, std::size_t payload_bytes, const char* what) {
  std::uint64_t n = 0;
  in >> n;
  if (n > payload_bytes) {
    throw std::invalid_argument(std::string(what) + " count " + std::to_string(n) +
                                " exceeds the payload");
  }
  return static_cast<std::size_t>(n);
}

std::vector<std::uint8_t> encodePayload(const MapSnapshot& map) {
  std::vector<std::uint8_t> bytes;
  auto out = mrpt::serialization::archiveFrom(bytes);
  out << static_cast<std::uint64_t>(map.params.size());
  for (const auto& [name, value] : map.params) out << name << value;
  out << static_cast<std::uint64_t>(map.sessions.size());
  for (const auto& s : map.sessions) {
    out << s.name << s.start_time << static_cast<std::int64_t>(s.first_node);
  }
  out << static_cast<std::uint64_t>(map.nodes.size());
  for (const auto& n : map.nodes) {
    out << static_cast<std::int64_t>(n.session) << n.timestamp;
    putPose(out, n.local_pose);
    putPose(out, n.map_pose);
    out << *n.scan;
  }
  out << static_cast<std::uint64_t>(map.edges.size());
  for (const auto& e : map.edges) {
    out << static_cast<std::int64_t>(e.from) << static_cast<std::int64_t>(e.to)
        << static_cast<std::uint8_t>(e.kind);
    putPose(out, e.measurement);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out << e.information(r, c);
    }
    out << static_cast<std::uint8_t>(e.verdict) << static_cast<std::int64_t>(e.cluster) << e.reason;
  }
  out << static_cast<std::uint64_t>(map.submaps.size());
  for (const auto& s : map.submaps) {
    out << static_cast<std::int64_t>(s.first_node) << static_cast<std::int64_t>(s.last_node);
  }
  return bytes;
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
  auto in = mrpt::serialization::archiveFrom(bytes);
  const std::size_t size = bytes.size();
  std::int64_t a = 0, b = 0;
  map.params.resize(getCount(in, size, "parameter"));
  for (auto& [name, value] : map.params) in >> name >> value;
  map.sessions.resize(getCount(in, size, "session"));
  for (auto& s : map.sessions) {
    in >> s.name >> s.start_time >> a;
    s.first_node = toInt(a, "session first node");
  }
  map.nodes.resize(getCount(in, size, "node"));
  for (auto& n : map.nodes) {
    in >> a >> n.timestamp;
    n.session = toInt(a, "node session");
    n.local_pose = getPose(in);
    n.map_pose = getPose(in);
    auto scan = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
    in >> *scan;
    n.scan = std::move(scan);
  }
  map.edges.resize(getCount(in, size, "edge"));
  for (auto& e : map.edges) {
    std::uint8_t kind = 0, verdict = 0;
    in >> a >> b >> kind;
    e.from = toInt(a, "edge from");
    e.to = toInt(b, "edge to");
    if (kind > 2) throw std::invalid_argument("edge kind " + std::to_string(kind) + " is unknown");
    e.kind = static_cast<MapSnapshot::EdgeKind>(kind);
    e.measurement = getPose(in);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) in >> e.information(r, c);
    }
    in >> verdict >> a >> e.reason;
    if (verdict > 2)
      throw std::invalid_argument("verdict " + std::to_string(verdict) + " is unknown");
    e.verdict = static_cast<rrr::Verdict>(verdict);
    e.cluster = toInt(a, "edge cluster");
  }
  map.submaps.resize(getCount(in, size, "submap"));
  for (auto& s : map.submaps) {
    in >> a >> b;
    s.first_node = toInt(a, "submap first node");
    s.last_node = toInt(b, "submap last node");
  }
  return map;
}

template <class T>
void putRaw(std::string& out, T value) {
  // Little-endian, as every platform this builds on; the payload itself is MRPT's portable one.
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
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    const int first = sessions[k].first_node;
    const int next = k + 1 < sessions.size() ? sessions[k + 1].first_node : n;
    if (first < 0 || first >= next || next > n) {
      fail("session " + std::to_string(k) + " starts at node " + std::to_string(first) +
           ", not before the next session or the end");
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
    if (!node.local_pose.allFinite() || !node.map_pose.allFinite() ||
        !std::isfinite(node.timestamp)) {
      fail("node " + std::to_string(k) + " has a pose or timestamp that is not finite");
    }
    if (node.scan == nullptr) fail("node " + std::to_string(k) + " has no scan");
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
    if (!e.measurement.allFinite() || !e.information.allFinite()) {
      fail("edge " + std::to_string(k) + " has a measurement or information that is not finite");
    }
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

void writeMapFile(const MapSnapshot& map, const std::string& path) {
  map.check();
  const std::vector<std::uint8_t> payload = encodePayload(map);
  uLongf packed_size = compressBound(static_cast<uLong>(payload.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, payload.data(),
                static_cast<uLong>(payload.size()), Z_DEFAULT_COMPRESSION) != Z_OK) {
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
  const std::string data((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (file.bad()) throw core::InputError(path, 0, "read error");
  auto fail = [&](const std::string& what) { throw core::InputError(path, 0, what); };
  if (data.size() < kHeaderBytes || std::memcmp(data.data(), kMagic, sizeof kMagic) != 0) {
    fail("not an rrr_graphslam map file (no RRRMAP header)");
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
  // The CRC held, so the size is what the writer wrote; bound it anyway (1000:1 is beyond zlib).
  if (payload_size > 1000 * (packed_size + 1)) fail("payload size is implausible");
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

core::PoseGraph mapPoseGraph(const MapSnapshot& map) {
  core::PoseGraph graph;
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    graph.addNode(static_cast<core::PoseGraph::NodeId>(k), map.nodes[k].map_pose);
  }
  for (const auto& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kMarginal) continue;
    graph.addEdge(static_cast<core::PoseGraph::NodeId>(e.from),
                  static_cast<core::PoseGraph::NodeId>(e.to), e.measurement, e.information,
                  e.kind == MapSnapshot::EdgeKind::kOdometry ? core::EdgeKind::kOdometry
                                                             : core::EdgeKind::kLoopCandidate);
  }
  return graph;
}

}  // namespace rrr_graphslam::frontend
