#pragma once
// The occupancy map of a laser SLAM run: every node's scan inserted at its map pose. Its inputs
// are a value that shares the scans, so another thread can render it while SLAM goes on.
//
// Layering: with every scan in one grid (kAllScans) a cell's occupancy weighs every observation
// of it alike, so where the world changed between sessions the sessions that saw the old state
// outvote the newest. kNewestSession renders each session on its own and takes each cell from
// the newest session that decided it (occupied or free by map_server's default thresholds): the map
// shows the world as the last robot to look saw it (a lifelong map's choice; within a session the
// world is taken to be still).
//
// Evidence: a rendered map weighs each ray more than a submap does. The submaps keep
// Cartographer's weak updates (hit 0.55, miss 0.49), which the matcher wants, but at those a cell
// needs about 35 rays through it before map_server's free threshold (0.196) calls it free: cells
// of one pass stay unknown, and where the world changed the newest session's view rarely decides
// a cell. The map's own probabilities (MapRenderParams) decide a cell in a few rays.
//
// Memory: a lifelong map's remembered cells (map_memory.h) are layers of their sessions. With
// kNewestSession a patch's cell shows where no newer session (kept scans or patch) decides the
// cell; with kAllScans, where the kept scans leave the cell unknown (newest patch first).

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/map_memory.h"
#include "rrr_graphslam/frontend/map_snapshot.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

enum class MapLayering { kAllScans, kNewestSession };

inline core::Choices<MapLayering> choices(MapLayering /*tag*/) {
  return {{MapLayering::kAllScans, "all"}, {MapLayering::kNewestSession, "newest-session"}};
}

/// Per-ray update of a rendered map's cells (MRPT's maxOccupancyUpdateCertainty and 1 -
/// maxFreenessUpdateCertainty); the other insertion options are the submaps'.
struct MapRenderParams {
  double hit_probability = 0.65;   ///< in [0.501, 0.99]: a ray ending in the cell
  double miss_probability = 0.45;  ///< in [0.01, 0.499]: a ray passing through it
};

/// The ROS parameters and command-line flags (--map-hit-probability, --map-miss-probability).
template <class Params, class F>
void forEachMapRenderParam(Params& p, F&& f) {
  f(core::ParamInfo{"map_hit_probability", 0.501, 0.99,
                    "per-ray update of a map cell a ray ends in (the submaps': 0.55)"},
    p.hit_probability);
  f(core::ParamInfo{"map_miss_probability", 0.01, 0.499,
                    "per-ray update of a map cell a ray passes through (the submaps': 0.49)"},
    p.miss_probability);
}

/// Throws std::invalid_argument (the table's message) for a value outside its range.
void validate(const MapRenderParams& params);

struct MapInputs {
  std::vector<core::Pose2> poses;  ///< map pose of every node
  std::vector<std::shared_ptr<const mrpt::obs::CObservation2DRangeScan>> scans;  ///< per node
  SubmapParams insertion;  ///< how a scan is inserted (ranges, occupancy probabilities)
  /// Per node, for kNewestSession and the memory: its session's number (newer sessions have
  /// larger numbers; empty: one session).
  std::vector<int> sessions;
  MapLayering layering = MapLayering::kAllScans;
  /// Unset: the submaps' own updates (a map to match scans against, as the matcher sees them).
  std::optional<MapRenderParams> render;
  /// Cells trimmed submaps decided (lifelong maps), anchored to nodes of `poses`.
  std::vector<RememberedCells> memory;
};

/// What a saved map's occupancy map is made of: every node's scan at its map pose, the sessions
/// by number, the memory; the insertion and render parameters left at their defaults.
MapInputs renderInputs(const MapSnapshot& map);

/// "all" or "newest-session".
std::string toString(MapLayering layering);
/// Parses "all" or "newest-session"; std::invalid_argument otherwise.
MapLayering parseMapLayering(const std::string& text);

/// The grid spans the trajectory's bounding box and grows to fit the rays. Throws
/// std::invalid_argument for render parameters out of range, or a map that would need more than
/// 2^28 cells (its span and its rays' reach at `resolution_m`).
mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m);

/// Where a remembered patch centred at a point of the map frame is anchored: a node and its map
/// pose.
using PatchAnchor = std::function<std::pair<int, core::Pose2>(const Eigen::Vector2d& centre)>;

/// The cells that `inputs`' scans (the leaving nodes of one session, at their map poses) decide
/// together, at the evidence of `inputs.render` (unset: MapRenderParams' defaults), in cells of
/// `resolution_m`, cut into square tiles of `tile_m` (each cropped to its decided cells, anchored
/// where `anchor` says for its centre, so that it moves with the part of the graph it lies by);
/// none if the scans decide no cell.
std::vector<RememberedCells> rememberScans(const MapInputs& inputs, double resolution_m,
                                           int session, double tile_m, const PatchAnchor& anchor);

/// `memory` (anchored to nodes at `poses`) without the cells a newer patch decides (a newer
/// session's, or a later one of the same session), compared in cells of `resolution_m` (the
/// patches'): each patch cropped to the cells left, empty ones dropped. Each cell keeps the
/// newest trimmed view of it: the memory is bounded by the area.
std::vector<RememberedCells> forgetSuperseded(const std::vector<RememberedCells>& memory,
                                              const std::vector<core::Pose2>& poses,
                                              double resolution_m);

}  // namespace rrr_graphslam::frontend
