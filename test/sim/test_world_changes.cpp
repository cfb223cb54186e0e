// Change sets: which cells a box or a door covers, in which session a change holds, and errors
// that name the file, the line and the entry.

#include <gtest/gtest.h>

#include <stdexcept>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/clearance_map.h"
#include "rrr_graphslam/sim/grid_planner.h"
#include "rrr_graphslam/sim/world_changes.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

using testing::writeTemp;

Cell cellAt(const World& w, double x, double y) {
  const Eigen::Vector2i c = w.cellOf({x, y});
  return w.at(c.x(), c.y());
}

TEST(WorldChanges, ApplyFromTheirSessionOn) {
  const ChangeSet set = readChanges(writeTemp("changes.yaml",
                                              "changes:\n"
                                              "  - {session: 1, kind: box, action: add, "
                                              "center: [1.0, 1.0], size: [0.6, 0.4], yaw: 0.5}\n"
                                              "  - session: 2\n"
                                              "    kind: door\n"
                                              "    action: close\n"
                                              "    from: [4.1, 3.0]\n"
                                              "    to: [4.1, 4.2]\n"
                                              "  - {session: 3, kind: box, action: remove, "
                                              "center: [1.0, 1.0], size: [0.8, 0.8]}\n"
                                              "  - {session: 3, kind: door, action: open, "
                                              "from: [4.1, 3.0], to: [4.1, 4.2]}\n"));
  ASSERT_EQ(set.changes.size(), 4U);
  EXPECT_EQ(set.changes[1].line, 3U);
  EXPECT_EQ(set.changes[1].label, "change 2");
  const World base = testing::twoRooms();
  validateChanges(set, base);
  const World w0 = worldOfSession(base, set, 0);
  const World w1 = worldOfSession(base, set, 1);
  const World w2 = worldOfSession(base, set, 2);
  const World w3 = worldOfSession(base, set, 3);
  EXPECT_TRUE(w0.cells == base.cells);
  // The box: its centre and a point along its rotated long axis, not a point beside it.
  EXPECT_EQ(cellAt(w1, 1.0, 1.0), Cell::kOccupied);
  EXPECT_EQ(cellAt(w1, 1.0 + 0.25 * std::cos(0.5), 1.0 + 0.25 * std::sin(0.5)), Cell::kOccupied);
  EXPECT_EQ(cellAt(w1, 1.0 - 0.25 * std::sin(0.5), 1.0 + 0.25 * std::cos(0.5)), Cell::kFree);
  EXPECT_EQ(cellAt(w1, 4.1, 3.6), Cell::kFree);  // the doorway is still open
  EXPECT_EQ(cellAt(w2, 1.0, 1.0), Cell::kOccupied);
  EXPECT_EQ(cellAt(w2, 4.1, 3.6), Cell::kOccupied);
  EXPECT_TRUE(w3.cells == base.cells);  // both undone
  // Only the covered cells change.
  std::size_t changed = 0;
  for (std::size_t i = 0; i < base.cells.size(); ++i) changed += w1.cells[i] != base.cells[i];
  World scratch = base;
  EXPECT_EQ(changed, applyChange(scratch, set.changes[0], base));
  EXPECT_NEAR(static_cast<double>(changed) * 0.01, 0.6 * 0.4, 0.06);
}

TEST(WorldChanges, ADiagonalDoorStopsEveryBeam) {
  World w(40, 40, 0.1, Eigen::Vector2d::Zero());
  WorldChange door;
  door.kind = WorldChange::Kind::kDoor;
  door.from_m = {0.5, 0.5};
  door.to_m = {3.5, 3.5};
  door.thickness_m = 0.01;  // thinner than a cell: still 4-connected
  const World drawn = w;
  applyChange(w, door, drawn);
  // No 4-connected step crosses the diagonal from one side to the other.
  for (int cy = 10; cy < 30; ++cy) {
    for (int cx = 10; cx < 30; ++cx) {
      if (w.at(cx, cy) != Cell::kFree) continue;
      const bool above = cy > cx;
      for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (w.at(cx + dx, cy + dy) != Cell::kFree) continue;
        EXPECT_EQ(cy + dy > cx + dx, above) << cx << "," << cy;
      }
    }
  }
}

TEST(WorldChanges, AnOpenedDoorLeavesTheWallsItsPostsStandIn) {
  // The doorway of twoRooms spans y 3.0-4.2 in the wall at x 4.0-4.2; the door is drawn from
  // wall to wall, its posts 0.3 m inside the wall on either side.
  const ChangeSet set = readChanges(writeTemp("door.yaml",
                                              "changes:\n"
                                              "  - {session: 1, kind: door, action: close, "
                                              "from: [4.1, 2.7], to: [4.1, 4.5]}\n"
                                              "  - {session: 2, kind: door, action: open, "
                                              "from: [4.1, 2.7], to: [4.1, 4.5]}\n"));
  const World base = testing::twoRooms();
  EXPECT_EQ(cellAt(base, 4.1, 2.8), Cell::kOccupied);
  EXPECT_EQ(cellAt(base, 4.1, 4.4), Cell::kOccupied);
  const World closed = worldOfSession(base, set, 1);
  for (const double y : {3.05, 3.6, 4.15}) EXPECT_EQ(cellAt(closed, 4.1, y), Cell::kOccupied) << y;
  const World opened = worldOfSession(base, set, 2);
  EXPECT_TRUE(opened.cells == base.cells);  // the doorway free again, the walls beside it whole
}

// An opened door gives back what lies beneath the doors: the boxes' changes before it count.
TEST(WorldChanges, AnOpenedDoorKeepsTheBoxesBeneathIt) {
  const World base = testing::twoRooms();
  ASSERT_EQ(cellAt(base, 4.1, 1.5), Cell::kOccupied);  // the wall below the doorway
  // A doorway cut by a box in session 1, a door closed in it in 2 and opened in 3: cut again.
  const ChangeSet cut = readChanges(writeTemp("cut.yaml",
                                              "changes:\n"
                                              "  - {session: 1, kind: box, action: remove, "
                                              "center: [4.1, 1.5], size: [0.4, 0.6]}\n"
                                              "  - {session: 2, kind: door, action: close, "
                                              "from: [4.1, 1.0], to: [4.1, 2.0]}\n"
                                              "  - {session: 3, kind: door, action: open, "
                                              "from: [4.1, 1.0], to: [4.1, 2.0]}\n"));
  validateChanges(cut, base);
  validateOpenings(cut, base);
  EXPECT_EQ(cellAt(worldOfSession(base, cut, 1), 4.1, 1.5), Cell::kFree);
  EXPECT_EQ(cellAt(worldOfSession(base, cut, 2), 4.1, 1.5), Cell::kOccupied);
  EXPECT_TRUE(worldOfSession(base, cut, 3).cells == worldOfSession(base, cut, 1).cells);
  // A box set down in the doorway in session 1 stays when a door over it closes and opens.
  const ChangeSet box = readChanges(writeTemp("box.yaml",
                                              "changes:\n"
                                              "  - {session: 1, kind: box, action: add, "
                                              "center: [4.1, 3.6], size: [0.2, 0.2]}\n"
                                              "  - {session: 2, kind: door, action: close, "
                                              "from: [4.1, 2.7], to: [4.1, 4.5]}\n"
                                              "  - {session: 3, kind: door, action: open, "
                                              "from: [4.1, 2.7], to: [4.1, 4.5]}\n"));
  const World reopened = worldOfSession(base, box, 3);
  EXPECT_EQ(cellAt(reopened, 4.1, 3.6), Cell::kOccupied);
  EXPECT_EQ(cellAt(reopened, 4.1, 3.1), Cell::kFree);
  EXPECT_TRUE(reopened.cells == worldOfSession(base, box, 1).cells);
  validateOpenings(box, base);
  // Opening a door that no change closed would change nothing (a wall stays a wall): refused,
  // naming the file and the line.
  const std::string open_path = writeTemp(
      "open.yaml",
      "changes:\n  - {session: 1, kind: box, action: add, center: [1, 1], size: [0.5, 0.5]}\n"
      "  - {session: 1, kind: door, action: open, from: [4.1, 1.0], to: [4.1, 2.0]}\n");
  const ChangeSet never_closed = readChanges(open_path);
  EXPECT_EQ(cellAt(worldOfSession(base, never_closed, 1), 4.1, 1.5), Cell::kOccupied);
  try {
    validateOpenings(never_closed, base);
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_EQ(e.source(), open_path);
    EXPECT_EQ(e.line(), 3U);
    EXPECT_NE(e.reason().find("change 2: opens a door no earlier change closed"), std::string::npos)
        << e.what();
  }
  // The world beneath must share the grid.
  World other(base.width, base.height, base.resolution_m * 2, base.origin_m);
  World scratch = base;
  EXPECT_THROW(applyChange(scratch, never_closed.changes[1], other), std::invalid_argument);
}

struct BadChange {
  std::string text;
  std::size_t line;
  std::string message;
};

TEST(WorldChanges, BadEntriesNameFileLineAndEntry) {
  const std::string ok = "  - {session: 1, kind: box, action: add, center: [1, 1], size: [1, 1]}\n";
  const std::vector<BadChange> cases = {
      {"changes:\n" + ok + "  - {session: 1, kind: boxx, action: add}\n", 3,
       "change 2: 'kind' must be box or door, not 'boxx'"},
      {"changes:\n" + ok + "  - session: 1\n    kind: box\n    action: grow\n", 5,
       "change 2: 'action' of a box must be add or remove, not 'grow'"},
      {"changes:\n  - {session: -1, kind: box, action: add, center: [1, 1], size: [1, 1]}\n", 2,
       "change 1: 'session' = -1 is out of range"},
      {"changes:\n  - {session: 1.5, kind: box, action: add, center: [1, 1], size: [1, 1]}\n", 2,
       "change 1: 'session' must be an integer"},
      {"changes:\n  - {session: 1, kind: box, action: add, center: [1], size: [1, 1]}\n", 2,
       "change 1: 'center' must be a list of 2 numbers"},
      {"changes:\n  - {session: 1, kind: box, action: add, center: [1, a], size: [1, 1]}\n", 2,
       "change 1: 'center' element 2 is not a finite number: 'a'"},
      {"changes:\n  - {session: 1, kind: box, action: add, center: [1, 1], size: [0, 1]}\n", 2,
       "change 1: 'size' must be positive"},
      {"changes:\n  - {session: 1, kind: box, action: add, size: [1, 1]}\n", 2,
       "change 1: 'center' is missing"},
      {"changes:\n  - {session: 1, kind: door, action: close, from: [1, 1], to: [1, 1]}\n", 2,
       "change 1: 'to' must differ from 'from'"},
      {"changes:\n" + ok +
           "  - session: 1\n    kind: door\n    action: open\n"
           "    from: [1, 1]\n    to: [2, 2]\n    width: 3\n",
       8, "change 2: 'width' is not a known field"},
      {"changes:\n  - just text\n", 2, "change 1 is not a map"},
      {"changes: 3\n", 1, "'changes' must be a list of entries"},
      {"chagnes: []\n", 1, "'chagnes' is not a known field"},
  };
  for (const BadChange& c : cases) {
    SCOPED_TRACE(c.message);
    const std::string path = writeTemp("bad_changes.yaml", c.text);
    try {
      readChanges(path);
      ADD_FAILURE() << "no error";
    } catch (const core::InputError& e) {
      EXPECT_EQ(e.source(), path);
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(e.reason().find(c.message), std::string::npos) << e.what();
    }
  }
}

TEST(WorldChanges, AChangeOutsideTheWorldIsRefused) {
  const std::string path = writeTemp(
      "far.yaml", "changes:\n" +
                      std::string("  - {session: 1, kind: box, action: add, center: [1, 1], "
                                  "size: [1, 1]}\n") +
                      "  - {session: 2, kind: box, action: add, center: [100, 1], size: [1, 1]}\n");
  const ChangeSet set = readChanges(path);
  try {
    validateChanges(set, testing::twoRooms());
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_EQ(e.line(), 3U);
    EXPECT_NE(e.reason().find("change 2: covers no cell of the world"), std::string::npos)
        << e.what();
  }
}

TEST(WorldChanges, TheBundledChangeSetsFitTheBundledWorld) {
  const std::string dir = std::string(RRR_TEST_DATA_DIR) + "/../../worlds/intel_lab/";
  const World base = readWorld(dir + "intel_lab.yaml");
  EXPECT_EQ(base.width, 291);
  EXPECT_EQ(base.height, 292);
  for (const char* name : {"furniture.yaml", "doors.yaml"}) {
    SCOPED_TRACE(name);
    const ChangeSet set = readChanges(dir + name);
    validateChanges(set, base);
    validateOpenings(set, base);
    for (int session = 1; session <= 3; ++session) {
      EXPECT_FALSE(worldOfSession(base, set, session).cells ==
                   worldOfSession(base, set, session - 1).cells)
          << "session " << session;
    }
  }
  // The doors: from the south corridor east of its door to the same corridor west of it, the
  // way round the ring is open in sessions 0, 1 and 3 and cut in session 2.
  const ChangeSet doors = readChanges(dir + "doors.yaml");
  for (int session = 0; session <= 3; ++session) {
    const World w = worldOfSession(base, doors, session);
    const ClearanceMap clearance(w);
    const GridPlanner planner(clearance, PlannerParams{});
    const auto path = planner.plan(w.cellOf({9.0, -18.8}), w.cellOf({0.0, -18.65}));
    EXPECT_EQ(path.has_value(), session != 2) << "session " << session;
  }
  // Once the south door has opened again (session 3) its cells are as the world file draws them:
  // the corridor's walls at its posts stay whole.
  const World reopened = worldOfSession(base, doors, 3);
  std::size_t walls = 0, doorway = 0;
  for (int cy = 0; cy < base.height; ++cy) {
    for (int cx = 0; cx < base.width; ++cx) {
      const Eigen::Vector2d p = base.centerOf(cx, cy);
      if (std::abs(p.x() - 7.5) > 0.3 || p.y() < -20.5 || p.y() > -17.2) continue;
      EXPECT_EQ(reopened.at(cx, cy), base.at(cx, cy)) << p.transpose();
      walls += base.at(cx, cy) == Cell::kOccupied;
      doorway += base.at(cx, cy) == Cell::kFree;
    }
  }
  EXPECT_GT(walls, 0U);
  EXPECT_GT(doorway, 0U);
}

}  // namespace
}  // namespace rrr_graphslam::sim
