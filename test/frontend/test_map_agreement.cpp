// Map agreement (negative information for relocalization): points on the room's walls agree,
// points in its free middle conflict, points the submap never saw say nothing; the bounding-box
// lookup over several placed submaps equals a brute-force pass over every submap and cell.

#include <gtest/gtest.h>

#include <random>

#include "rrr_graphslam/frontend/map_agreement.h"
#include "rrr_graphslam/frontend/submap.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

using testing::castScan;
using testing::room;

// A finished submap of the room seen from a few poses; its frame is the room's shifted by
// `frame` (the local SLAM frame of a session whose odometry started elsewhere).
std::unique_ptr<Submap> roomSubmap(int index, const core::Pose2& frame) {
  const RangeScanParams scan_params;
  auto submap = std::make_unique<Submap>(index, 0, core::compose(frame, core::Pose2(3, 2, 0)),
                                         SubmapParams{});
  int node = 0;
  for (const core::Pose2& p : {core::Pose2(3.0, 2.0, 0.0), core::Pose2(6.0, 2.5, 0.5),
                               core::Pose2(9.0, 3.0, 1.0), core::Pose2(6.0, 6.0, -2.0)}) {
    for (int k = 0; k < 15; ++k) {
      submap->insert(toObservation(castScan(room(), p), scan_params), core::compose(frame, p),
                     node++);
    }
  }
  submap->finish();
  return submap;
}

TEST(MapAgreement, WallsAgreeFreeSpaceConflictsUnseenSaysNothing) {
  const auto submap = roomSubmap(0, core::Pose2(0, 0, 0));
  // The anchor's map pose equals its local pose: map frame = room frame.
  const std::vector<PlacedSubmap> map = {placeSubmap(*submap, submap->anchorPose())};
  const MapAgreementParams params;
  std::vector<Eigen::Vector2d> wall, middle, outside;
  for (int i = 1; i < 20; ++i) {
    wall.emplace_back(0.5 + 0.5 * i, 0.03);  // on the room's south wall, its inner side
    middle.emplace_back(5.0 + 0.1 * i, 2.0);
    outside.emplace_back(30.0 + i, 30.0);
  }
  const MapAgreement on_wall = mapAgreement(map, wall, params);
  EXPECT_EQ(on_wall.points, 19);
  EXPECT_EQ(on_wall.known, 19);
  EXPECT_EQ(on_wall.conflicting, 0);
  const MapAgreement in_middle = mapAgreement(map, middle, params);
  EXPECT_EQ(in_middle.known, 19);
  EXPECT_EQ(in_middle.conflicting, 19);
  EXPECT_DOUBLE_EQ(in_middle.conflictFraction(), 1.0);
  const MapAgreement far = mapAgreement(map, outside, params);
  EXPECT_EQ(far.known, 0);
  EXPECT_EQ(far.conflictFraction(), 0.0);
  EXPECT_FALSE(far.contradicts(params, 0.0));  // nothing known: no evidence

  MapAgreementParams few = params;
  few.min_known_points = 10;
  EXPECT_TRUE(in_middle.contradicts(few, 0.5));
  EXPECT_FALSE(on_wall.contradicts(few, 0.5));
  few.min_known_points = 20;  // 19 known points are too few
  EXPECT_FALSE(in_middle.contradicts(few, 0.5));
}

TEST(MapAgreement, ScansOfThePlaceAgreeAndAShiftedPlacementConflicts) {
  // The room's submap built in a session frame far from the map frame, placed by its anchor's map
  // pose: a scan from (7.5, 2.5) agrees where it was taken and conflicts moved 2 m north.
  const core::Pose2 frame(40.0, -15.0, 1.2);
  const auto submap = roomSubmap(0, frame);
  const std::vector<PlacedSubmap> map = {placeSubmap(*submap, core::Pose2(3, 2, 0))};
  const RangeScanParams scan_params;
  const PointCloud points =
      matchingPoints(castScan(room(), core::Pose2(7.5, 2.5, 0.3)), scan_params);
  auto placed = [&](const core::Pose2& pose) {
    std::vector<Eigen::Vector2d> out;
    for (const Eigen::Vector2d& q : points)
      out.push_back(core::rotation(pose.z()) * q + pose.head<2>());
    return out;
  };
  const MapAgreementParams params;
  const MapAgreement right = mapAgreement(map, placed(core::Pose2(7.5, 2.5, 0.3)), params);
  const MapAgreement wrong = mapAgreement(map, placed(core::Pose2(7.5, 4.5, 0.3)), params);
  EXPECT_GT(right.known, 100);
  EXPECT_LT(right.conflictFraction(), 0.05);
  EXPECT_GT(wrong.known, 100);
  EXPECT_GT(wrong.conflictFraction(), 0.3);
}

// Brute force: every submap, every point, the cell and its window read one by one.
MapAgreement bruteForce(const std::vector<PlacedSubmap>& map,
                        const std::vector<Eigen::Vector2d>& points,
                        const MapAgreementParams& params) {
  MapAgreement out;
  for (const Eigen::Vector2d& p : points) {
    ++out.points;
    int observing = 0;
    int saw_free = 0;
    for (const PlacedSubmap& s : map) {
      const MatchGrid& grid = s.submap->matchGrid();
      const Eigen::Vector2d q =
          core::rotation(s.submap_from_map.z()) * p + s.submap_from_map.head<2>();
      const int cx = static_cast<int>(std::floor((q.x() - grid.origin().x()) / grid.resolution()));
      const int cy = static_cast<int>(std::floor((q.y() - grid.origin().y()) / grid.resolution()));
      if (!grid.contains(cx, cy) || grid.at(cx, cy) == grid.unknown()) continue;
      ++observing;
      bool all_free = true;
      for (int x = cx - params.tolerance_cells; x <= cx + params.tolerance_cells; ++x) {
        for (int y = cy - params.tolerance_cells; y <= cy + params.tolerance_cells; ++y) {
          const float v = grid.at(x, y);
          if (v == grid.unknown() || v >= params.free_below) all_free = false;
        }
      }
      saw_free += all_free ? 1 : 0;
    }
    if (observing == 0) continue;
    ++out.known;
    if (saw_free == observing) ++out.conflicting;
  }
  return out;
}

TEST(MapAgreement, BoundingBoxLookupEqualsBruteForce) {
  std::vector<std::unique_ptr<Submap>> submaps;
  std::vector<PlacedSubmap> map;
  const std::vector<core::Pose2> frames = {{0, 0, 0}, {25, 3, 2.0}, {-7, 11, -0.7}};
  const std::vector<core::Pose2> anchors_in_map = {{3, 2, 0}, {8, 5, 0.4}, {3.5, 2.5, -0.1}};
  for (std::size_t k = 0; k < frames.size(); ++k) {
    submaps.push_back(roomSubmap(static_cast<int>(k), frames[k]));
    map.push_back(placeSubmap(*submaps.back(), anchors_in_map[k]));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-4.0, 20.0), y(-4.0, 16.0);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 20000; ++i) points.emplace_back(x(rng), y(rng));
  const MapAgreementParams params;
  const MapAgreement fast = mapAgreement(map, points, params);
  const MapAgreement slow = bruteForce(map, points, params);
  EXPECT_EQ(fast.points, slow.points);
  EXPECT_EQ(fast.known, slow.known);
  EXPECT_EQ(fast.conflicting, slow.conflicting);
  EXPECT_GT(slow.known, 2000);       // the points cover the submaps...
  EXPECT_GT(slow.conflicting, 500);  // ...free space
  EXPECT_LT(slow.conflicting, slow.known);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
