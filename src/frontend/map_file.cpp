#include "rrr_graphslam/frontend/map_file.h"

#include <zlib.h>

#include <cstring>
#include <fstream>
#include <stdexcept>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/map_payload.h"

namespace rrr_graphslam::frontend {
namespace {

constexpr char kMagic[8] = {'R', 'R', 'R', 'M', 'A', 'P', '\n', '\0'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 8 + 8 + 4;
// Payloads are held in memory whole; beyond this a file is refused rather than allocated.
constexpr std::uint64_t kMaxPayloadBytes = std::uint64_t{1} << 31;

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

void writeMapFile(const MapSnapshot& map, const std::string& path) {
  map.check();
  const std::string payload = encodeMapPayload(map);
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
    MapSnapshot map = decodeMapPayload(payload, version);
    map.check();
    return map;
  } catch (const std::exception& e) {
    fail(std::string("malformed payload: ") + e.what());
  }
  return {};
}

}  // namespace rrr_graphslam::frontend
