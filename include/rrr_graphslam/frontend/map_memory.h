#pragma once
// The map's memory of what trimming removed (lifelong maps, doc/lifelong.md): when a submap is
// trimmed its scans leave the map, and with them the newest view of any cell that no kept scan
// decides (a door only that session saw closed, a box its rays alone reached). Trimming keeps
// those cells as patches: every cell a session's leaving scans observed together, stamped with
// the session, in tiles each anchored to a node that stays, so a patch moves with the graph when
// later sessions re-optimize it (rtabmap's local grids ride with their nodes the same way). A
// cell is a decision (occupied or free at the rendered map's evidence and map_server's
// thresholds) or evidence (glimpsed: its probability, which does not decide it).
//
// The rendered map (map_render.h) takes each cell from the newest session that decides it, among
// the kept scans' sessions and the patches' decisions; where none decides a cell, the patches'
// evidence adds to the kept scans' (as the untrimmed map's scans of several sessions would add
// up). When a map is trimmed, a remembered cell that a newer patch decides is forgotten, and
// evidence under a newer patch's evidence is added to it and forgotten (a sum that decides the
// cell becomes the newer patch's decision); a patch left empty is dropped. So the memory holds
// one value per cell of the area at most: it grows with the area, not with time. (A remembered
// cell that a newer kept session decides stays, hidden: that session's own patches may not
// decide it when they come.) The memory is drawn in the map only: scan matching and
// relocalization use the kept submaps.

#include <cstdint>
#include <memory>
#include <vector>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::frontend {

/// The cells a trimmed submap's scans decided: a patch of grid, axis-aligned in its own frame.
struct RememberedCells {
  /// Cell values: 0 unknown, else 1 + 254 * the probability that the cell is free (MRPT's
  /// getCell()), rounded (rememberedValue()). A value up to kLastOccupied or from kFirstFree is a
  /// decision (map_server's default thresholds read it occupied or free); one between is
  /// evidence: the cell was glimpsed, not decided, and its log-odds add up with other sessions'
  /// where no session decides the cell.
  static constexpr std::uint8_t kUnknown = 0;
  static constexpr std::uint8_t kLastOccupied = 89;  ///< 88 / 254 free: occupancy 0.654
  static constexpr std::uint8_t kFirstFree = 206;    ///< 205 / 254 free: occupancy 0.193
  /// The most cells a patch may hold (a 10 m tile at 5 cm holds 40000).
  static constexpr int kMaxCells = 1 << 24;

  int session = 0;      ///< MapSnapshot::Session::number of the session whose scans decided them
  int anchor_node = 0;  ///< the node the patch moves with
  /// The patch frame in the anchor node's frame: cell (i, j) spans [i, i + 1) x [j, j + 1) times
  /// resolution_m from its origin.
  core::Pose2 origin = core::Pose2::Zero();
  double resolution_m = 0.05;
  int width = 0;                                           ///< cells along x
  int height = 0;                                          ///< cells along y
  std::shared_ptr<const std::vector<std::uint8_t>> cells;  ///< row-major, width * height

  /// Throws std::invalid_argument naming what is wrong (sizes, a non-finite origin, a resolution
  /// out of [0.001, 10] m, more than kMaxCells cells, an anchor outside [0, nodes)).
  void check(int nodes) const;
  /// Cells that are not unknown (decisions and evidence).
  std::size_t knownCells() const;
};

/// Encodes a probability of being free in a cell's value: a decision (occupancy at least 0.65
/// or at most 0.196, map_server's defaults) stays one, evidence stays evidence.
std::uint8_t rememberedValue(float free_probability);
/// The probability of being free a cell's value stands for.
float freeProbability(std::uint8_t value);
/// Whether a (known) cell's value is a decision rather than evidence.
bool isDecision(std::uint8_t value);
/// The occupancy log-odds log(p(occupied) / p(free)) of a probability of being free, of a
/// value, and back.
float occupancyLogOdds(float free_probability);
float evidenceLogOdds(std::uint8_t value);
float freeProbabilityOfLogOdds(float log_odds);

/// The patch's pose in the map frame, given its anchor node's map pose.
core::Pose2 patchPose(const RememberedCells& patch, const core::Pose2& anchor_map_pose);

/// The same patch anchored to another node (`anchor_map_pose` and `new_anchor_map_pose` at the
/// same estimate of the graph): its cells stay where they are in the map.
RememberedCells reanchored(const RememberedCells& patch, const core::Pose2& anchor_map_pose,
                           int new_anchor, const core::Pose2& new_anchor_map_pose);

/// Known cells (decisions and evidence) of every patch.
std::size_t rememberedCells(const std::vector<RememberedCells>& memory);

}  // namespace rrr_graphslam::frontend
