#pragma once
// The map file's payload (map_file.h): a MapSnapshot as a sequence of little-endian records, in
// the order of its fields: parameters, sessions, nodes with their scans, edges, submaps, then
// what later versions added (the lifelong counts, the memory of trimmed submaps, dense factors).
// A record's count is checked against the bytes left before anything is allocated: MRPT's own
// deserializers allocate from lengths in the data first, which a file read from a robot's disk
// cannot allow.

#include <cstdint>
#include <string>
#include <vector>

#include "rrr_graphslam/frontend/map_snapshot.h"

namespace rrr_graphslam::frontend {

/// `map` as its format_version lays it out (the fields an older version cannot hold must be empty:
/// MapSnapshot::check).
std::string encodeMapPayload(const MapSnapshot& map);

/// The map `bytes` hold in format `version`, not yet checked for consistency (MapSnapshot::check).
/// Throws std::invalid_argument naming what is malformed: a record cut short, a count larger than
/// the bytes left, a value out of range or not finite, bytes after the last record.
MapSnapshot decodeMapPayload(const std::vector<std::uint8_t>& bytes, std::uint32_t version);

}  // namespace rrr_graphslam::frontend
