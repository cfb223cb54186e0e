#pragma once
// Rival readings of where a session lies. A session continuing a map is tied to it by the first
// group of agreeing loops that spans relocalization_confirm_distance (rrr/session_placement.h);
// where the building looks the same from two poses (ACES turned by 180 degrees, the next of two
// alike corridors) the other reading may have as much support, and once the session is tied only
// the winner would be searched again, around where it puts each node, so it alone keeps gathering
// loops. The session's loops to the map that RRR does not accept each say where they put the
// session's newest node; the largest group of them that agree is the rival reading, which the
// front end searches too (LaserSlam, LoopSearchParams::rival_min_loops), so RRR's decisions from
// scratch can still place the session by whichever reading gathered more.

#include <cstddef>
#include <optional>
#include <vector>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

/// Where one loop to the map puts the session's newest node (its map end where the map has it,
/// the session's shape as the map has it), and the loop's end in the session.
struct SessionReading {
  core::Pose2 pose;
  int session_node;
};

/// Two readings agree when they put the node within these of each other.
struct ReadingAgreement {
  double distance_m = 2.0;
  double angle_rad = 0.2;
};

bool readingsAgree(const core::Pose2& a, const core::Pose2& b, const ReadingAgreement& within);

/// The readings that agree with the one most others agree with (itself included; the first such
/// reading among equals), if there are at least `min_size` of them: the pose of their newest
/// (largest session_node, the first among equals; the session's drift since is least) and their
/// number, else nullopt. O(n) per reading
/// through a grid of distance_m cells.
struct ReadingGroup {
  core::Pose2 pose;  ///< where its newest reading puts the node
  std::size_t size;  ///< readings in the group
};
std::optional<ReadingGroup> largestReading(const std::vector<SessionReading>& readings,
                                           std::size_t min_size,
                                           const ReadingAgreement& within = {});

}  // namespace rrr_graphslam::frontend
