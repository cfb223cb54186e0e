#pragma once
// Negative information for relocalization. A match between a new session and the map says where
// the session is; it also says where every earlier node of the session was, and what the map
// knows there. Where the session's scans then end in space the map has seen free, the placement
// is contradicted: the robot saw a wall where the map saw through. A building's aliased places
// (the same corridor twice, a corridor seen from its other end) match a single scan equally well;
// the path that led there rarely fits both. Olson ("Recognizing places using spectrally clustered
// local matches", RAS 2009) argues the same for loop closing: a match is trusted when nothing else
// explains the data as well, and data that does not fit is evidence too.
//
// The test counts the session's scan endpoints that fall on cells some finished submap of the map
// observed, and of those, the ones every such submap has seen free (with a tolerance of a few
// cells for the placement's and the grids' own error).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

class Submap;

struct MapAgreementParams {
  /// A cell whose occupancy probability is below this is known free; default 0.4 (a cell the
  /// submap's scans crossed a dozen times more often than they ended in it).
  float free_below = 0.4F;
  /// A point agrees with the map when any cell within this many of its own is not known free
  /// (default 2: 10 cm at the default resolution).
  int tolerance_cells = 2;
  /// Fewer points on observed cells than this say nothing either way (default 100).
  int min_known_points = 100;
};

struct MapAgreement {
  int points = 0;       ///< points tested
  int known = 0;        ///< of those, on cells a submap observed
  int conflicting = 0;  ///< of those, in space every observing submap saw free
  double conflictFraction() const {
    return known > 0 ? static_cast<double>(conflicting) / known : 0.0;
  }
  /// Enough known points, and more than `max_fraction` of them conflicting.
  bool contradicts(const MapAgreementParams& params, double max_fraction) const {
    return known >= params.min_known_points && conflictFraction() > max_fraction;
  }
};

/// A finished submap where the map estimate puts it.
struct PlacedSubmap {
  const Submap* submap = nullptr;
  core::Pose2 submap_from_map;  ///< a map-frame pose or point in the submap's frame
  Eigen::AlignedBox2d box;      ///< the submap's grid in the map frame
};

/// `submap` (finished) placed by the map pose of its anchor node.
PlacedSubmap placeSubmap(const Submap& submap, const core::Pose2& anchor_map_pose);

/// How the points (map frame) agree with the submaps.
MapAgreement mapAgreement(const std::vector<PlacedSubmap>& map,
                          const std::vector<Eigen::Vector2d>& points,
                          const MapAgreementParams& params);

}  // namespace rrr_graphslam::frontend
