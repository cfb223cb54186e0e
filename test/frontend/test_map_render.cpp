// The occupancy map of several sessions in a world that changed between them: every scan alike,
// or each cell as the newest session that saw it.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>

#include "rrr_graphslam/frontend/map_render.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

using testing::castScan;
using testing::room;
using testing::Segment;
using testing::truthAt;

// Occupancy (not MRPT's free probability) at a point.
double occupancyAt(const mrpt::maps::COccupancyGridMap2D& grid, double x, double y) {
  return 1.0 - grid.getPos(static_cast<float>(x), static_cast<float>(y));
}

// Sessions 0-2 drive a lap around a box at (7.5, 2.5) that session 3 finds gone: three laps
// saw it, one did not.
MapInputs boxThatLeft() {
  std::vector<Segment> with_box = room();
  with_box.push_back({{7.2, 2.2}, {7.8, 2.2}});
  with_box.push_back({{7.8, 2.2}, {7.8, 2.8}});
  with_box.push_back({{7.8, 2.8}, {7.2, 2.8}});
  with_box.push_back({{7.2, 2.8}, {7.2, 2.2}});
  MapInputs inputs;
  const RangeScanParams params;
  for (int session = 0; session < 4; ++session) {
    for (int k = 0; k < 105; k += 3) {
      const RangeScan scan = castScan(session < 3 ? with_box : room(), truthAt(k));
      inputs.poses.push_back(truthAt(k));
      inputs.scans.push_back(
          std::make_shared<mrpt::obs::CObservation2DRangeScan>(toObservation(scan, params)));
      inputs.sessions.push_back(session);
    }
  }
  return inputs;
}

TEST(MapRender, TheNewestSessionShowsTheWorldAsItIsNow) {
  MapInputs inputs = boxThatLeft();
  // Every scan alike: three sessions of the box outvote the one without it.
  const auto all = renderOccupancyMap(inputs, 0.05);
  EXPECT_GT(occupancyAt(all, 7.8, 2.5), 0.65);
  // The newest session decides where it looked: the box is gone, the walls stay.
  inputs.layering = MapLayering::kNewestSession;
  const auto newest = renderOccupancyMap(inputs, 0.05);
  EXPECT_LT(occupancyAt(newest, 7.8, 2.5), 0.196);
  EXPECT_LT(occupancyAt(newest, 7.2, 2.5), 0.196);
  EXPECT_GT(occupancyAt(newest, 12.0, 2.5), 0.65);  // a wall every session saw
  EXPECT_GT(occupancyAt(newest, 4.0, 1.5), 0.65);
  EXPECT_EQ(newest.getSizeX(), all.getSizeX());
  // One session: the same map either way.
  inputs.sessions.assign(inputs.sessions.size(), 0);
  const auto one = renderOccupancyMap(inputs, 0.05);
  EXPECT_NEAR(occupancyAt(one, 7.8, 2.5), occupancyAt(all, 7.8, 2.5), 1e-6);
}

// One glimpse of a room: a few scans from one place. With the submaps' weak updates (no render
// parameters: what the matcher sees) the floor they saw through stays undecided for map_server;
// the rendered map's own updates call it free, and the walls occupied, after those few rays.
TEST(MapRender, TheMapsOwnUpdatesDecideWhatOnePassSaw) {
  MapInputs inputs;
  const RangeScanParams params;
  for (int k = 0; k < 3; ++k) {
    inputs.poses.push_back(truthAt(0));
    inputs.scans.push_back(std::make_shared<mrpt::obs::CObservation2DRangeScan>(
        toObservation(castScan(room(), truthAt(0)), params)));
  }
  const core::Pose2 at = truthAt(0);
  const double fx = at.x() + 1.0 * std::cos(at.z());  // 1 m ahead: a few rays pass through
  const double fy = at.y() + 1.0 * std::sin(at.z());
  const auto matcher = renderOccupancyMap(inputs, 0.05);
  EXPECT_GT(occupancyAt(matcher, fx, fy), 0.196);  // unknown for map_server
  EXPECT_LT(occupancyAt(matcher, fx, fy), 0.5);
  inputs.render = MapRenderParams{};
  const auto rendered = renderOccupancyMap(inputs, 0.05);
  EXPECT_LT(occupancyAt(rendered, fx, fy), 0.196);
  EXPECT_GT(occupancyAt(rendered, 12.0, 2.5), 0.65);  // the wall the scans end on
  // Out of range: a miss that would mark cells occupied, a hit that would clear them.
  inputs.render->miss_probability = 0.6;
  EXPECT_THROW(renderOccupancyMap(inputs, 0.05), std::invalid_argument);
  inputs.render = MapRenderParams{};
  inputs.render->hit_probability = 0.4;
  try {
    validate(*inputs.render);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "map_hit_probability = 0.4 is out of range: must be in [0.501, 0.99]");
  }
}

// A run continuing a map hands its nodes' sessions to the renderer, as the map file has them.
TEST(MapRender, LaserSlamNamesEachNodesSession) {
  LaserSlamParams params;
  params.local.submap.scans_per_submap = 20;
  params.loops.threads = 1;
  LaserSlam first(params, "one");
  testing::drive(first, core::Pose2::Zero(), 60, 0.0);
  auto second = LaserSlam::fromMap(first.snapshot(), params, "two");
  testing::drive(*second, core::Pose2(2.0, 1.0, 0.5), 60, 100.0);
  const MapInputs inputs = second->mapInputs();
  const MapSnapshot map = second->snapshot();
  ASSERT_EQ(inputs.sessions.size(), map.nodes.size());
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    EXPECT_EQ(inputs.sessions[k], map.nodes[k].session) << k;
  }
  EXPECT_EQ(inputs.sessions.front(), 0);
  EXPECT_EQ(inputs.sessions.back(), 1);
}

TEST(MapRender, LayeringNamesRoundTrip) {
  for (MapLayering l : {MapLayering::kAllScans, MapLayering::kNewestSession}) {
    EXPECT_EQ(parseMapLayering(toString(l)), l);
  }
  EXPECT_THROW(parseMapLayering("oldest"), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
