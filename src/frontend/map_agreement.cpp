#include "rrr_graphslam/frontend/map_agreement.h"

#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {
namespace {

Eigen::Vector2d transformPoint(const core::Pose2& T, const Eigen::Vector2d& p) {
  return core::rotation(T.z()) * p + T.head<2>();
}

// Whether the point (submap frame) lies on a cell the grid observed, and if so whether every cell
// of the tolerance window around it is known free.
struct CellVerdict {
  bool known = false;
  bool free = false;
};

CellVerdict verdictAt(const MatchGrid& grid, const Eigen::Vector2d& q,
                      const MapAgreementParams& params) {
  const Eigen::Array2i cell = grid.cellOf(q);
  const float unknown = grid.unknown();
  if (!grid.contains(cell.x(), cell.y()) || grid.at(cell.x(), cell.y()) == unknown) return {};
  const int r = params.tolerance_cells;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const float v = grid.at(cell.x() + dx, cell.y() + dy);
      // Unknown cells near the point do not count as free: a wall at the edge of what the
      // submap saw.
      if (v == unknown || v >= params.free_below) return {true, false};
    }
  }
  return {true, true};
}

void countPoint(const std::vector<PlacedSubmap>& map, const Eigen::Vector2d& p,
                const MapAgreementParams& params, MapAgreement& out) {
  ++out.points;
  bool known = false;
  bool free_everywhere = true;
  for (const PlacedSubmap& s : map) {
    if (!s.box.contains(p)) continue;
    const CellVerdict v =
        verdictAt(s.submap->matchGrid(), transformPoint(s.submap_from_map, p), params);
    if (!v.known) continue;
    known = true;
    if (!v.free) {
      free_everywhere = false;
      break;
    }
  }
  if (!known) return;
  ++out.known;
  if (free_everywhere) ++out.conflicting;
}

}  // namespace

PlacedSubmap placeSubmap(const Submap& submap, const core::Pose2& anchor_map_pose) {
  PlacedSubmap placed;
  placed.submap = &submap;
  // map -> local (submap) frame: the anchor's local pose composed with its map pose's inverse.
  placed.submap_from_map = core::compose(submap.anchorPose(), core::inverse(anchor_map_pose));
  const MatchGrid& grid = submap.matchGrid();
  const core::Pose2 map_from_submap = core::inverse(placed.submap_from_map);
  const Eigen::Vector2d size(grid.width() * grid.resolution(), grid.height() * grid.resolution());
  for (int corner = 0; corner < 4; ++corner) {
    const Eigen::Vector2d local =
        grid.origin() +
        Eigen::Vector2d((corner & 1) != 0 ? size.x() : 0.0, (corner & 2) != 0 ? size.y() : 0.0);
    placed.box.extend(transformPoint(map_from_submap, local));
  }
  return placed;
}

MapAgreement mapAgreement(const std::vector<PlacedSubmap>& map,
                          const std::vector<Eigen::Vector2d>& points,
                          const MapAgreementParams& params) {
  MapAgreement out;
  for (const Eigen::Vector2d& p : points) countPoint(map, p, params, out);
  return out;
}

}  // namespace rrr_graphslam::frontend
