// The occupancy map of several sessions in a world that changed between them: every scan alike,
// or each cell as the newest session that saw it.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "rrr_graphslam/frontend/map_io.h"
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

// One lap of `world` (every third scan) as nodes of session `session`.
MapInputs lapOf(const std::vector<Segment>& world, int session) {
  MapInputs inputs;
  const RangeScanParams params;
  for (int k = 0; k < 105; k += 3) {
    inputs.poses.push_back(truthAt(k));
    inputs.scans.push_back(std::make_shared<mrpt::obs::CObservation2DRangeScan>(
        toObservation(castScan(world, truthAt(k)), params)));
    inputs.sessions.push_back(session);
  }
  return inputs;
}

std::vector<Segment> roomWithBox() {
  std::vector<Segment> world = room();
  world.push_back({{7.2, 2.2}, {7.8, 2.2}});
  world.push_back({{7.8, 2.2}, {7.8, 2.8}});
  world.push_back({{7.8, 2.8}, {7.2, 2.8}});
  world.push_back({{7.2, 2.8}, {7.2, 2.2}});
  return world;
}

// Sessions 0-2 drive a lap around a box at (7.5, 2.5) that session 3 finds gone: three laps
// saw it, one did not.
MapInputs boxThatLeft() {
  MapInputs inputs;
  for (int session = 0; session < 4; ++session) {
    const MapInputs lap = lapOf(session < 3 ? roomWithBox() : room(), session);
    inputs.poses.insert(inputs.poses.end(), lap.poses.begin(), lap.poses.end());
    inputs.scans.insert(inputs.scans.end(), lap.scans.begin(), lap.scans.end());
    inputs.sessions.insert(inputs.sessions.end(), lap.sessions.begin(), lap.sessions.end());
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
    EXPECT_EQ(inputs.sessions[k],
              map.sessions[static_cast<std::size_t>(map.nodes[k].session)].number)
        << k;
  }
  EXPECT_EQ(inputs.sessions.front(), 0);
  EXPECT_EQ(inputs.sessions.back(), 1);
  EXPECT_EQ(map.sessions.back().number, 1);
}

// Cells whose probabilities differ between two grids of the same bounds (all of them if the
// bounds differ).
int differingCells(const mrpt::maps::COccupancyGridMap2D& a,
                   const mrpt::maps::COccupancyGridMap2D& b) {
  if (a.getSizeX() != b.getSizeX() || a.getSizeY() != b.getSizeY()) {
    ADD_FAILURE() << "the grids' sizes differ";
    return std::numeric_limits<int>::max();
  }
  int differ = 0;
  for (unsigned y = 0; y < a.getSizeY(); ++y) {
    for (unsigned x = 0; x < a.getSizeX(); ++x) {
      differ += std::abs(a.getCell(x, y) - b.getCell(x, y)) > 1e-3F;
    }
  }
  return differ;
}

// The cells `lap` decides, as one patch (tiles larger than the room) anchored to node `anchor`
// at `poses`.
RememberedCells rememberedLap(const MapInputs& lap, int session,
                              const std::vector<core::Pose2>& poses, int anchor) {
  const std::vector<RememberedCells> patches =
      rememberScans(lap, 0.05, session, 100.0, [&](const Eigen::Vector2d&) {
        return std::pair{anchor, poses[static_cast<std::size_t>(anchor)]};
      });
  EXPECT_EQ(patches.size(), 1u);
  return patches.empty() ? RememberedCells{} : patches.front();
}

// A lap of session 1 saw a box that the kept lap (session `kept_session`) did not: the lap's
// scans left the map, its decided cells are remembered, anchored to the kept lap's node 5.
MapInputs keptLapAndRememberedBox(int kept_session) {
  MapInputs inputs = lapOf(room(), kept_session);
  inputs.memory.push_back(rememberedLap(lapOf(roomWithBox(), 1), 1, inputs.poses, 5));
  inputs.render = MapRenderParams{};
  inputs.layering = MapLayering::kNewestSession;
  return inputs;
}

TEST(MapRender, RememberedCellsShowWhereNoNewerSessionDecidesThem) {
  // The box's session is newer than the kept lap's: the box shows.
  MapInputs inputs = keptLapAndRememberedBox(0);
  ASSERT_EQ(inputs.memory.size(), 1u);
  EXPECT_EQ(inputs.memory[0].anchor_node, 5);
  EXPECT_GT(inputs.memory[0].knownCells(), 1000u);
  EXPECT_GT(occupancyAt(renderOccupancyMap(inputs, 0.05), 7.2, 2.5), 0.65);
  // Without the memory the kept lap shows the floor there.
  MapInputs forgotten = inputs;
  forgotten.memory.clear();
  EXPECT_LT(occupancyAt(renderOccupancyMap(forgotten, 0.05), 7.2, 2.5), 0.196);
  // Older than the kept lap: the kept lap's floor wins; every scan alike: the scans decide the
  // floor, the memory only fills what they leave unknown.
  inputs = keptLapAndRememberedBox(2);
  EXPECT_LT(occupancyAt(renderOccupancyMap(inputs, 0.05), 7.2, 2.5), 0.196);
  inputs.layering = MapLayering::kAllScans;
  EXPECT_LT(occupancyAt(renderOccupancyMap(inputs, 0.05), 7.2, 2.5), 0.196);
  // No scans left at all: the memory alone is the map (its walls and the box).
  inputs.scans.clear();
  const auto alone = renderOccupancyMap(inputs, 0.05);
  EXPECT_GT(occupancyAt(alone, 7.2, 2.5), 0.65);
  EXPECT_GT(occupancyAt(alone, 12.0, 2.5), 0.65);
  EXPECT_LT(occupancyAt(alone, 5.0, 2.5), 0.196);
}

TEST(MapRender, RememberedCellsMoveWithTheirAnchor) {
  MapInputs inputs = keptLapAndRememberedBox(0);
  inputs.scans.clear();  // the memory alone
  // The whole map moved (a later session's re-optimization): 1 m along x, turned 0.2 rad about
  // the origin. The box moves with the anchor.
  const core::Pose2 moved(1.0, 0.0, 0.2);
  for (core::Pose2& x : inputs.poses) x = core::compose(moved, x);
  const auto grid = renderOccupancyMap(inputs, 0.05);
  for (const Eigen::Vector2d& wall :
       {Eigen::Vector2d(7.2, 2.5), Eigen::Vector2d(7.5, 2.2), Eigen::Vector2d(12.0, 2.5)}) {
    const core::Pose2 there = core::compose(moved, core::Pose2(wall.x(), wall.y(), 0.0));
    EXPECT_GT(occupancyAt(grid, there.x(), there.y()), 0.65) << wall.transpose();
  }
  // Re-anchored to another node, at the same estimate: nothing moves.
  MapInputs again = inputs;
  again.memory[0] = reanchored(inputs.memory[0], inputs.poses[5], 20, inputs.poses[20]);
  EXPECT_EQ(again.memory[0].anchor_node, 20);
  // A cell centre on a patch cell's edge may round the other way.
  EXPECT_LE(differingCells(grid, renderOccupancyMap(again, 0.05)), 20);
}

// A session's remembered cells come in tiles, each anchored to the node nearest it; together
// they render as the one patch does.
TEST(MapRender, RememberedTilesAreAnchoredNearThemAndRenderAsOnePatch) {
  const MapInputs kept = lapOf(room(), 2);
  const MapInputs box = lapOf(roomWithBox(), 1);
  std::vector<Eigen::Vector2d> centres;
  const std::vector<RememberedCells> tiles =
      rememberScans(box, 0.05, 1, 4.0, [&](const Eigen::Vector2d& centre) {
        centres.push_back(centre);
        int nearest = 0;
        for (std::size_t k = 0; k < kept.poses.size(); ++k) {
          if ((kept.poses[k].head<2>() - centre).norm() <
              (kept.poses[static_cast<std::size_t>(nearest)].head<2>() - centre).norm()) {
            nearest = static_cast<int>(k);
          }
        }
        return std::pair{nearest, kept.poses[static_cast<std::size_t>(nearest)]};
      });
  // The room is 12 m x 8 m: 3 x 2 tiles of 4 m and more (the grid's margins), each within one.
  ASSERT_GE(tiles.size(), 6u);
  std::size_t cells = 0;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    EXPECT_LE(tiles[t].width, 80);
    EXPECT_LE(tiles[t].height, 80);
    EXPECT_EQ(tiles[t].session, 1);
    cells += tiles[t].knownCells();
  }
  const RememberedCells whole = rememberedLap(box, 1, kept.poses, 5);
  EXPECT_EQ(cells, whole.knownCells());
  std::set<int> anchors;
  for (const RememberedCells& tile : tiles) anchors.insert(tile.anchor_node);
  EXPECT_GT(anchors.size(), 2u);
  MapInputs tiled;
  tiled.poses = kept.poses;
  tiled.memory = tiles;
  MapInputs one = tiled;
  one.memory = {whole};
  // Cell centres on a tile's edge may round the other way.
  EXPECT_LE(differingCells(renderOccupancyMap(tiled, 0.05), renderOccupancyMap(one, 0.05)), 50);
}

// A remembered wall one 5 cm cell thick, in front of free floor, rendered at 10 cm: every cell
// the wall passes through shows it (as a scan's hit would), wherever the lattices fall.
TEST(MapRender, AThinRememberedWallShowsInACoarserMap) {
  for (double shift : {0.0, 0.013, 0.025, 0.04}) {
    MapInputs inputs;
    inputs.poses = {core::Pose2(shift, shift, 0.0)};
    RememberedCells patch;
    patch.anchor_node = 0;
    patch.resolution_m = 0.05;
    patch.width = 40;
    patch.height = 20;
    std::vector<std::uint8_t> cells(40 * 20, rememberedValue(0.9F));          // free floor
    for (int i = 0; i < 40; ++i) cells[10 * 40 + i] = rememberedValue(0.1F);  // y in [0.5, 0.55)
    patch.cells = std::make_shared<const std::vector<std::uint8_t>>(cells);
    inputs.memory = {patch};
    const auto grid = renderOccupancyMap(inputs, 0.1);
    for (double x = 0.1; x < 1.9; x += 0.1) {
      const double wall = std::max(occupancyAt(grid, shift + x, shift + 0.5),
                                   occupancyAt(grid, shift + x, shift + 0.549));
      EXPECT_GT(wall, 0.65) << "x " << x << " shift " << shift;
      EXPECT_LT(occupancyAt(grid, shift + x, shift + 0.25), 0.196) << x;  // the floor stays free
    }
  }
}

TEST(MapRender, RememberedValuesKeepDecisionsAndEvidenceApart) {
  for (float p = 0.0F; p <= 1.0F; p += 0.001F) {
    const std::uint8_t v = rememberedValue(p);
    const bool decided = 1.0F - p >= 0.65F || 1.0F - p <= 0.196F;  // map_server's defaults
    EXPECT_EQ(isDecision(v), decided) << p;
    // As a map_server reader sees it.
    EXPECT_EQ(isDecision(v), mapServerPixel(1.0F - freeProbability(v)) != 205) << p;
    if (!decided) {
      EXPECT_NEAR(freeProbability(v), p, 0.5F / 254.0F + 1e-6F) << p;
    }
  }
  EXPECT_FALSE(isDecision(RememberedCells::kUnknown));
  EXPECT_NEAR(evidenceLogOdds(rememberedValue(0.4F)), std::log(0.6F / 0.4F), 0.02F);
}

// A patch of `n` x `n` 5 cm cells at the origin, every one glimpsed free (p(free) 0.7: no
// decision for map_server), of `session`, anchored to node 0.
RememberedCells glimpse(int session, int n = 20) {
  RememberedCells patch;
  patch.session = session;
  patch.resolution_m = 0.05;
  patch.width = patch.height = n;
  patch.cells = std::make_shared<const std::vector<std::uint8_t>>(static_cast<std::size_t>(n * n),
                                                                  rememberedValue(0.7F));
  return patch;
}

// Forgetting what is already forgotten changes nothing: no cell's evidence is added twice
// (forgetSuperseded runs at every trim, over the patches the earlier trims left).
void expectForgettingIsIdempotent(const std::vector<RememberedCells>& memory,
                                  const std::vector<core::Pose2>& poses) {
  const std::vector<RememberedCells> once = forgetSuperseded(memory, poses, 0.05);
  const std::vector<RememberedCells> twice = forgetSuperseded(once, poses, 0.05);
  ASSERT_EQ(twice.size(), once.size());
  for (std::size_t p = 0; p < once.size(); ++p) {
    EXPECT_EQ(twice[p].session, once[p].session) << p;
    EXPECT_EQ(twice[p].width, once[p].width) << p;
    EXPECT_EQ(twice[p].height, once[p].height) << p;
    EXPECT_LT((twice[p].origin - once[p].origin).norm(), 1e-12) << p;
    EXPECT_EQ(*twice[p].cells, *once[p].cells) << p;
  }
}

// What several sessions glimpsed adds up where none decided: two glimpses of the floor decide
// it free, one does not (the untrimmed map's scans would add up the same way).
TEST(MapRender, GlimpsesOfSeveralSessionsAddUpWhereNoneDecides) {
  MapInputs inputs;
  inputs.poses = {core::Pose2::Zero()};
  inputs.layering = MapLayering::kNewestSession;
  inputs.memory = {glimpse(1)};
  EXPECT_NEAR(occupancyAt(renderOccupancyMap(inputs, 0.05), 0.5, 0.5), 0.5, 0.01);  // unknown
  inputs.memory = {glimpse(1), glimpse(2)};
  const auto both = renderOccupancyMap(inputs, 0.05);
  EXPECT_LT(occupancyAt(both, 0.5, 0.5), 0.196);
  // At 10 cm a glimpse counts once per cell, not once per 5 cm cell under it.
  inputs.memory = {glimpse(1)};
  EXPECT_NEAR(occupancyAt(renderOccupancyMap(inputs, 0.1), 0.5, 0.5), 0.5, 0.01);
  inputs.memory = {glimpse(1), glimpse(2)};
  EXPECT_LT(occupancyAt(renderOccupancyMap(inputs, 0.1), 0.5, 0.5), 0.196);
  // A newer decision overrules the glimpses: session 3 saw the cells occupied.
  RememberedCells wall = glimpse(3);
  wall.cells = std::make_shared<const std::vector<std::uint8_t>>(400, rememberedValue(0.1F));
  inputs.memory.push_back(wall);
  EXPECT_GT(occupancyAt(renderOccupancyMap(inputs, 0.05), 0.5, 0.5), 0.65);

  // Forgetting keeps one value per cell: the older glimpse is added to the newer one (which
  // they decide together: a decision of the newer session), the two render as before; under
  // the newer decision, both glimpses are forgotten.
  const std::vector<RememberedCells> fused =
      forgetSuperseded({glimpse(1), glimpse(2)}, inputs.poses, 0.05);
  ASSERT_EQ(fused.size(), 1u);
  EXPECT_EQ(fused[0].session, 2);
  EXPECT_EQ(fused[0].knownCells(), 400u);
  EXPECT_TRUE(isDecision(fused[0].cells->front()));
  EXPECT_NEAR(freeProbability(fused[0].cells->front()), 0.845F, 0.005F);  // 0.7 twice
  inputs.memory = fused;
  EXPECT_EQ(differingCells(renderOccupancyMap(inputs, 0.05), both), 0);
  const std::vector<RememberedCells> decided =
      forgetSuperseded({glimpse(1), glimpse(2), wall}, inputs.poses, 0.05);
  ASSERT_EQ(decided.size(), 1u);
  EXPECT_EQ(decided[0].session, 3);
  // An older glimpse turned by the graph (0.1 rad about its anchor) and coarser (10 cm) is added
  // to the newer one once per cell: the newer cells get at most one older cell's evidence
  // each (2 x 0.85), never several.
  RememberedCells turned = glimpse(1, 10);
  turned.resolution_m = 0.1;
  turned.origin = core::Pose2(0.0, 0.0, 0.1);
  const std::vector<RememberedCells> once =
      forgetSuperseded({turned, glimpse(2)}, inputs.poses, 0.05);
  ASSERT_FALSE(once.empty());
  for (std::uint8_t v : *once.back().cells) {
    if (v == RememberedCells::kUnknown) continue;
    EXPECT_LE(freeProbability(v), 0.85F);  // 0.7 and 0.7: 0.845; more would be double counting
  }
  // Forgetting leaves the rendered map as it was, also where the older cells straddle grid
  // cells with and without newer evidence.
  MapInputs straddling = inputs;
  straddling.memory = {turned, glimpse(2)};
  MapInputs forgotten = straddling;
  forgotten.memory = once;
  EXPECT_EQ(
      differingCells(renderOccupancyMap(straddling, 0.05), renderOccupancyMap(forgotten, 0.05)), 0);
  // Coarser patches than the forgetting's cells, aligned: an older cell meets the same newer
  // owner in each of the four cells both cover, and is added to it once.
  RememberedCells coarse_old = glimpse(1, 10);
  coarse_old.resolution_m = 0.1;
  RememberedCells coarse_new = glimpse(2, 10);
  coarse_new.resolution_m = 0.1;
  MapInputs coarse = inputs;
  coarse.memory = {coarse_old, coarse_new};
  MapInputs coarse_forgotten = coarse;
  coarse_forgotten.memory = forgetSuperseded(coarse.memory, inputs.poses, 0.05);
  ASSERT_EQ(coarse_forgotten.memory.size(), 1u);
  EXPECT_NEAR(freeProbability(coarse_forgotten.memory[0].cells->front()), 0.845F, 0.005F);
  EXPECT_EQ(
      differingCells(renderOccupancyMap(coarse, 0.05), renderOccupancyMap(coarse_forgotten, 0.05)),
      0);
  expectForgettingIsIdempotent(coarse.memory, inputs.poses);
  expectForgettingIsIdempotent({glimpse(1), glimpse(2)}, inputs.poses);
  expectForgettingIsIdempotent({turned, glimpse(2)}, inputs.poses);
  expectForgettingIsIdempotent({turned, glimpse(2, 10), glimpse(3)}, inputs.poses);
}

TEST(MapRender, RememberedCellsThatANewerPatchDecidesAreForgotten) {
  // Two trimmed laps of the room, both remembered: one saw the box (session 1), one did not
  // (session `room_session`), both anchored to the kept lap's node 5.
  auto memoryOf = [](int room_session) {
    MapInputs kept = lapOf(room(), 3);
    std::vector<RememberedCells> memory;
    for (const auto& [world, session] :
         {std::pair{roomWithBox(), 1}, std::pair{room(), room_session}}) {
      memory.push_back(rememberedLap(lapOf(world, session), session, kept.poses, 5));
    }
    return std::pair{kept.poses, memory};
  };
  // The lap without the box is newer: it decides nearly every cell the box's lap decided, which
  // are forgotten (a few at the edges of what each decides stay: the patches' lattices differ by
  // a fraction of a cell). The newer patch keeps all of its cells.
  auto [poses, memory] = memoryOf(2);
  const std::size_t box_cells = memory[0].knownCells();
  const std::size_t room_cells = memory[1].knownCells();
  std::vector<RememberedCells> left = forgetSuperseded(memory, poses, 0.05);
  expectForgettingIsIdempotent(memory, poses);
  ASSERT_GE(left.size(), 1u);
  ASSERT_LE(left.size(), 2u);
  EXPECT_EQ(left.back().knownCells(), room_cells);
  EXPECT_LT(rememberedCells(left) - room_cells, box_cells / 20);
  for (const RememberedCells& patch : left) EXPECT_NO_THROW(patch.check(35));
  // What is rendered is unchanged by forgetting: the newer lap's floor where the box was.
  MapInputs before;
  before.poses = poses;
  before.memory = memory;
  before.layering = MapLayering::kNewestSession;
  MapInputs after = before;
  after.memory = left;
  EXPECT_LT(occupancyAt(renderOccupancyMap(after, 0.05), 7.2, 2.5), 0.196);
  EXPECT_LT(occupancyAt(renderOccupancyMap(before, 0.05), 7.2, 2.5), 0.196);

  // The lap without the box is older (session 0): the box's lap, newer, keeps all its cells; the
  // older keeps only what the newer does not decide (about nothing: the box hides little).
  std::tie(poses, memory) = memoryOf(0);
  left = forgetSuperseded(memory, poses, 0.05);
  ASSERT_GE(left.size(), 1u);
  EXPECT_EQ(left.front().session, 1);
  EXPECT_EQ(left.front().knownCells(), box_cells);
  EXPECT_LT(rememberedCells(left) - box_cells, room_cells / 20);
  after.memory = left;
  EXPECT_GT(occupancyAt(renderOccupancyMap(after, 0.05), 7.2, 2.5), 0.65);

  // Kept scans never make a remembered cell forgotten: a newer kept session hides it only.
  MapInputs hidden = keptLapAndRememberedBox(2);
  EXPECT_EQ(rememberedCells(forgetSuperseded(hidden.memory, hidden.poses, 0.05)),
            hidden.memory[0].knownCells());
}

// Two nodes 100 km apart (a map file may place them so): refused before MRPT counts the cells
// in 32 bits; at 10 m cells it renders.
TEST(MapRender, AMapTooLargeToRenderIsRefusedNotBuilt) {
  MapInputs inputs;
  inputs.poses = {core::Pose2::Zero(), core::Pose2(1e5, 1e5, 0.0)};
  try {
    renderOccupancyMap(inputs, 0.05);
    ADD_FAILURE() << "rendered";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("render it coarser"), std::string::npos) << e.what();
  }
  inputs.poses = {core::Pose2::Zero(), core::Pose2(1e5, 1e5, 0.0)};
  EXPECT_NO_THROW(renderOccupancyMap(inputs, 10.0));
}

TEST(MapRender, LayeringNamesRoundTrip) {
  for (MapLayering l : {MapLayering::kAllScans, MapLayering::kNewestSession}) {
    EXPECT_EQ(parseMapLayering(toString(l)), l);
  }
  EXPECT_THROW(parseMapLayering("oldest"), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
