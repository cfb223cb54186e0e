#pragma once
// Step 5 of lifelong trimming (map_trimming.h): the map's memory (map_memory.h) when a trim's
// leaving nodes go. At the trusted graph's estimate the trim linearizes at, the memory's patches
// whose anchor leaves move to the nearest node that stays, and each session's leaving scans are
// remembered (decisions and evidence, in 10 m tiles anchored to the nearest staying node); once
// the trimmed map is numbered, the anchors follow, and the cells newer patches decide are
// forgotten.

#include <cstddef>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/map_memory.h"
#include "rrr_graphslam/frontend/map_snapshot.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

/// The memory between the trim's two steps: anchors still in the input map's numbering.
struct TrimmedMemory {
  std::vector<RememberedCells> patches;
  int made_patches = 0;  ///< of the leaving scans
};

/// The memory of `map` when the nodes without `stays` leave, at `poses` (the input map's
/// numbering); with `remember`, the leaving scans' patches are added (if a node stays).
TrimmedMemory memoryAfterTrim(const MapSnapshot& map, const std::vector<core::Pose2>& poses,
                              const std::vector<char>& stays, const TrimParams& params,
                              const SubmapParams& submap_params, bool remember);

/// Renumbers the anchors by `new_index` (every anchor stays) and, if patches were made, forgets
/// the cells a newer patch decides, at the poses of `trimmed`. Returns the cells forgotten.
std::size_t settleMemory(TrimmedMemory& memory, const std::vector<int>& new_index,
                         const MapSnapshot& trimmed, const TrimParams& params);

}  // namespace rrr_graphslam::frontend
