#pragma once
// The map file (*.rrrmap): a MapSnapshot (map_snapshot.h) on disk.
//
// Layout (doc/design.md, "The map file"): an 8-byte magic "RRRMAP\n\0", the format version
// (uint32), the payload's size and its compressed size (uint64 each), the CRC-32 of the
// compressed payload (uint32), then the payload compressed with zlib. The payload is a sequence
// of little-endian records (map_payload.h) whose every length is checked against the bytes left
// before anything is allocated.
// Files are written atomically and read all or nothing: a truncated, corrupted, unknown or newer
// file is an InputError naming the file and what is wrong.

#include <string>

#include "rrr_graphslam/frontend/map_snapshot.h"

namespace rrr_graphslam::frontend {

/// Writes `map` to `path` atomically, in its format_version. Throws std::runtime_error naming the
/// path.
void writeMapFile(const MapSnapshot& map, const std::string& path);
/// Reads a map file. Throws core::InputError naming the file and what is wrong.
MapSnapshot readMapFile(const std::string& path);

}  // namespace rrr_graphslam::frontend
