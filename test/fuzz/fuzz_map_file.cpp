// libFuzzer target of frontend::readMapFile (the *.rrrmap map file), in two modes chosen by the
// input's first bytes:
//
// - an input that starts with the file's magic "RRRMAP\n\0" is a whole file, read as it is: the
//   header checks (version, sizes, CRC-32, the stated payload size, decompression);
// - any other input is an uncompressed payload: it is compressed with zlib and given a valid
//   version-1 header with the right sizes and CRC, so that the CRC, which rejects nearly every
//   mutation of a whole file, does not stop the fuzzer before MRPT's CArchive decoding, the
//   counts and MapSnapshot::check(). (A payload starts with the parameter count, a little-endian
//   uint64, so it never starts with the magic in practice.)
//
// A bad input must throw InputError (map_file.h: "every fault"). Besides crashes, sanitizer
// errors, timeouts and allocations beyond the 2 GB limit, it checks for an accepted map that
// MapSnapshot::check() passes, that every bool of its scans holds 0 or 1 (CArchive reads a bool
// as a raw byte), that mapPoseGraph builds its graph, and that writeMapFile then readMapFile
// gives the same snapshot: every field bit for bit, scans by their ranges, validity, intensities
// and scalar fields.

#include <stdlib.h>
#include <unistd.h>
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "fuzz_input.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/map_file.h"

namespace rrr_graphslam::fuzz {
namespace {

using frontend::MapSnapshot;

constexpr char kMagic[8] = {'R', 'R', 'R', 'M', 'A', 'P', '\n', '\0'};

template <class T>
void putLittleEndian(std::string& out, T value) {
  for (std::size_t k = 0; k < sizeof(T); ++k) {
    out.push_back(static_cast<char>((static_cast<std::uint64_t>(value) >> (8 * k)) & 0xff));
  }
}

// A whole file of `version` around `payload`, as writeMapFile lays it out.
std::string wrapPayload(std::uint32_t version, const std::uint8_t* payload, std::size_t size) {
  uLongf packed_size = compressBound(static_cast<uLong>(size));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, payload,
                static_cast<uLong>(size), Z_BEST_SPEED) != Z_OK) {
    std::fprintf(stderr, "[fuzz] compress2 failed\n");
    std::abort();
  }
  packed.resize(packed_size);
  std::string file(kMagic, sizeof kMagic);
  putLittleEndian<std::uint32_t>(file, version);
  putLittleEndian<std::uint64_t>(file, size);
  putLittleEndian<std::uint64_t>(file, packed.size());
  putLittleEndian<std::uint32_t>(
      file, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(packed.data()),
                                             static_cast<uInt>(packed.size()))));
  return file + packed;
}

template <class T>
bool sameBits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

bool samePose(const core::Pose2& a, const core::Pose2& b) {
  return sameBits(a.x(), b.x()) && sameBits(a.y(), b.y()) && sameBits(a.z(), b.z());
}

// CArchive reads a bool by copying a byte into it: anything but 0 or 1 is undefined behaviour
// for whoever reads the field.
bool validBool(const bool& b) {
  unsigned char byte = 0;
  std::memcpy(&byte, &b, 1);
  return byte <= 1;
}

bool sameScan(const mrpt::obs::CObservation2DRangeScan& a,
              const mrpt::obs::CObservation2DRangeScan& b) {
  if (a.getScanSize() != b.getScanSize() || a.hasIntensity() != b.hasIntensity()) return false;
  for (std::size_t i = 0; i < a.getScanSize(); ++i) {
    if (!sameBits(a.getScanRange(i), b.getScanRange(i)) ||
        a.getScanRangeValidity(i) != b.getScanRangeValidity(i)) {
      return false;
    }
    if (a.hasIntensity() && a.getScanIntensity(i) != b.getScanIntensity(i)) return false;
  }
  return sameBits(a.aperture, b.aperture) && a.rightToLeft == b.rightToLeft &&
         sameBits(a.maxRange, b.maxRange) && sameBits(a.stdError, b.stdError) &&
         sameBits(a.beamAperture, b.beamAperture) && sameBits(a.deltaPitch, b.deltaPitch) &&
         a.sensorLabel == b.sensorLabel &&
         a.timestamp.time_since_epoch().count() == b.timestamp.time_since_epoch().count() &&
         // The sensor pose is written as a quaternion: only x, y, z are copied as they are.
         sameBits(a.sensorPose.x(), b.sensorPose.x()) &&
         sameBits(a.sensorPose.y(), b.sensorPose.y()) &&
         sameBits(a.sensorPose.z(), b.sensorPose.z());
}

bool sameMap(const MapSnapshot& a, const MapSnapshot& b) {
  if (a.format_version != b.format_version || a.params != b.params ||
      a.sessions.size() != b.sessions.size() || a.nodes.size() != b.nodes.size() ||
      a.edges.size() != b.edges.size() || a.submaps.size() != b.submaps.size() ||
      a.lifelong.trimmed_submaps != b.lifelong.trimmed_submaps ||
      a.lifelong.marginalized_nodes != b.lifelong.marginalized_nodes) {
    return false;
  }
  for (std::size_t k = 0; k < a.sessions.size(); ++k) {
    const auto &sa = a.sessions[k], &sb = b.sessions[k];
    if (sa.name != sb.name || !sameBits(sa.start_time, sb.start_time) ||
        sa.first_node != sb.first_node || sa.number != sb.number) {
      return false;
    }
  }
  if (a.dense_factors.size() != b.dense_factors.size()) return false;
  for (std::size_t k = 0; k < a.dense_factors.size(); ++k) {
    const auto &fa = a.dense_factors[k], &fb = b.dense_factors[k];
    if (fa.nodes != fb.nodes || fa.measurements.size() != fb.measurements.size() ||
        fa.mean.size() != fb.mean.size() || fa.information.size() != fb.information.size() ||
        !sameBits(fa.chi2_offset, fb.chi2_offset)) {
      return false;
    }
    for (std::size_t i = 0; i < fa.measurements.size(); ++i) {
      if (!samePose(fa.measurements[i], fb.measurements[i])) return false;
    }
    if (std::memcmp(fa.mean.data(), fb.mean.data(), sizeof(double) * fa.mean.size()) != 0 ||
        std::memcmp(fa.information.data(), fb.information.data(),
                    sizeof(double) * fa.information.size()) != 0) {
      return false;
    }
  }
  if (a.memory.size() != b.memory.size()) return false;
  for (std::size_t k = 0; k < a.memory.size(); ++k) {
    const auto &pa = a.memory[k], &pb = b.memory[k];
    if (pa.session != pb.session || pa.anchor_node != pb.anchor_node ||
        !samePose(pa.origin, pb.origin) || !sameBits(pa.resolution_m, pb.resolution_m) ||
        pa.width != pb.width || pa.height != pb.height || *pa.cells != *pb.cells) {
      return false;
    }
  }
  for (std::size_t k = 0; k < a.nodes.size(); ++k) {
    const auto &na = a.nodes[k], &nb = b.nodes[k];
    if (na.session != nb.session || !sameBits(na.timestamp, nb.timestamp) ||
        !samePose(na.local_pose, nb.local_pose) || !samePose(na.map_pose, nb.map_pose) ||
        !sameScan(*na.scan, *nb.scan)) {
      return false;
    }
  }
  for (std::size_t k = 0; k < a.edges.size(); ++k) {
    const auto &ea = a.edges[k], &eb = b.edges[k];
    if (ea.from != eb.from || ea.to != eb.to || ea.kind != eb.kind ||
        !samePose(ea.measurement, eb.measurement) ||
        std::memcmp(ea.information.data(), eb.information.data(), 9 * sizeof(double)) != 0 ||
        ea.verdict != eb.verdict || ea.cluster != eb.cluster || ea.reason != eb.reason) {
      return false;
    }
  }
  for (std::size_t k = 0; k < a.submaps.size(); ++k) {
    if (a.submaps[k].first_node != b.submaps[k].first_node ||
        a.submaps[k].last_node != b.submaps[k].last_node) {
      return false;
    }
  }
  return true;
}

// writeMapFile writes a temporary beside its target and renames it, so it needs a real folder:
// one per process under TMPDIR (scripts/fuzz points it to a folder in /dev/shm that it removes
// at exit), else in /dev/shm.
class ScratchFile {
 public:
  ScratchFile() {
    const char* tmpdir = std::getenv("TMPDIR");
    const char* base = tmpdir != nullptr && *tmpdir != '\0' ? tmpdir
                       : access("/dev/shm", W_OK) == 0      ? "/dev/shm"
                                                            : "/tmp";
    std::string name = std::string(base) + "/rrr_fuzz_map_file.XXXXXX";
    if (mkdtemp(name.data()) == nullptr) {
      std::perror("[fuzz] mkdtemp");
      std::abort();
    }
    dir_ = name;
    path_ = dir_ + "/roundtrip.rrrmap";
  }
  ~ScratchFile() {
    std::remove(path_.c_str());
    rmdir(dir_.c_str());
  }
  const std::string& path() const { return path_; }

 private:
  std::string dir_, path_;
};

void checkAccepted(const MapSnapshot& map) {
  try {
    map.check();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[fuzz] check: %s\n", e.what());
    RRR_FUZZ_CHECK(false, "an accepted map passes MapSnapshot::check()");
  }
  RRR_FUZZ_CHECK(map.format_version >= 1 && map.format_version <= frontend::kMapFormatVersion,
                 "the version read is one this build reads");
  for (const auto& node : map.nodes) {
    RRR_FUZZ_CHECK(validBool(node.scan->rightToLeft), "a scan's rightToLeft is 0 or 1");
  }
  try {
    const core::PoseGraph graph = frontend::mapPoseGraph(map);
    RRR_FUZZ_CHECK(graph.numNodes() == map.nodes.size(), "the map's graph has every node");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[fuzz] mapPoseGraph: %s\n", e.what());
    RRR_FUZZ_CHECK(false, "the graph of an accepted map can be built");
  }

  static const ScratchFile scratch;
  try {
    frontend::writeMapFile(map, scratch.path());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[fuzz] writeMapFile: %s\n", e.what());
    RRR_FUZZ_CHECK(false, "an accepted map can be written");
  }
  MapSnapshot again;
  try {
    again = frontend::readMapFile(scratch.path());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[fuzz] reading the written map back failed: %s\n", e.what());
    RRR_FUZZ_CHECK(false, "a map the reader accepted is written in a form it accepts");
  }
  RRR_FUZZ_CHECK(sameMap(map, again), "write then read gives the same map");
}

}  // namespace
}  // namespace rrr_graphslam::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace core = rrr_graphslam::core;
  namespace fuzz = rrr_graphslam::fuzz;
  namespace frontend = rrr_graphslam::frontend;
  const bool whole_file =
      size >= sizeof fuzz::kMagic && std::memcmp(data, fuzz::kMagic, sizeof fuzz::kMagic) == 0;
  std::string wrapped;
  if (!whole_file) {
    // A payload of the version its first two bytes name ("V2" .. "V5": the later sections), or
    // of version 1.
    std::uint32_t version = 1;
    if (size >= 2 && data[0] == 'V' && data[1] >= '1' &&
        data[1] < '1' + static_cast<int>(frontend::kMapFormatVersion)) {
      version = static_cast<std::uint32_t>(data[1] - '0');
      data += 2;
      size -= 2;
    }
    wrapped = fuzz::wrapPayload(version, data, size);
  }
  const std::string& path =
      whole_file
          ? fuzz::writeInput(data, size)
          : fuzz::writeInput(reinterpret_cast<const std::uint8_t*>(wrapped.data()), wrapped.size());
  frontend::MapSnapshot map;
  try {
    map = frontend::readMapFile(path);
  } catch (const core::InputError&) {
    return 0;  // a bad input, reported as the reader promises
  } catch (const std::exception& e) {
    fuzz::unexpectedException(e);
  }
  fuzz::checkAccepted(map);
  return 0;
}
