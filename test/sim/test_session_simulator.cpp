// Whole sessions: repeatable from their seed, in free space, dated and framed as documented, in
// the world of their own session, and written as logs the product's reader reads.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/carmen_log.h"
#include "rrr_graphslam/sim/clearance_map.h"
#include "rrr_graphslam/sim/session_simulator.h"
#include "rrr_graphslam/sim/world_changes.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

SimulationParams shortSessions() {
  SimulationParams p;
  p.waypoints = 4;
  p.max_scans = 400;
  return p;
}

TEST(SessionSimulator, TheSameSeedRepeatsAnotherDiffers) {
  const World w = testing::twoRooms();
  const SimulationParams p = shortSessions();
  const SimulatedSession a = simulateSession(w, 0, p, 5);
  const SimulatedSession b = simulateSession(w, 0, p, 5);
  const SimulatedSession c = simulateSession(w, 0, p, 6);
  const SimulatedSession d = simulateSession(w, 1, p, 5);
  EXPECT_EQ(a.truth, b.truth);
  EXPECT_EQ(a.odometry, b.odometry);
  EXPECT_EQ(a.ranges, b.ranges);
  EXPECT_NE(a.truth, c.truth);
  EXPECT_NE(a.truth, d.truth);                        // another session, another route
  EXPECT_NE(a.odometry.front(), d.odometry.front());  // and another odometry frame
  // The route does not depend on the noise settings.
  SimulationParams exact = p;
  exact.odometry = {0, 0, 0, 0};
  exact.laser.range_stddev_m = 0.0;
  EXPECT_EQ(simulateSession(w, 0, exact, 5).truth, a.truth);
}

TEST(SessionSimulator, DrivesThroughFreeSpaceAtItsRateAndDate) {
  const World w = testing::twoRooms();
  SimulationParams p = shortSessions();
  p.max_scans = 0;  // to the last waypoint
  const SimulatedSession s = simulateSession(w, 2, p, 9);
  ASSERT_GT(s.truth.size(), 100U);
  ASSERT_EQ(s.stamps.size(), s.truth.size());
  ASSERT_EQ(s.ranges.size(), s.truth.size());
  EXPECT_DOUBLE_EQ(s.stamps.front(), p.start_time_s + 2 * p.session_gap_s);
  const ClearanceMap clearance(w);
  double top_speed = 0.0;
  for (std::size_t k = 0; k < s.truth.size(); ++k) {
    const Eigen::Vector2i c = w.cellOf(s.truth[k].head<2>());
    // Pure pursuit cuts corners a little; it never comes near a wall.
    EXPECT_GE(clearance.at(c.x(), c.y()), 0.25) << k;
    if (k == 0) continue;
    EXPECT_NEAR(s.stamps[k] - s.stamps[k - 1], 1.0 / p.scan_rate_hz, 1e-6);
    const double speed = (s.truth[k].head<2>() - s.truth[k - 1].head<2>()).norm() * p.scan_rate_hz;
    top_speed = std::max(top_speed, speed);
  }
  EXPECT_LE(top_speed, p.motion.max_speed_mps + 1e-9);
  EXPECT_GT(top_speed, 0.9 * p.motion.max_speed_mps);
  // It reached its last waypoint.
  EXPECT_LT((s.truth.back().head<2>() - s.waypoints_m.back()).norm(), 0.1);
  EXPECT_EQ(s.waypoints_m.size(), 5U);
}

TEST(SessionSimulator, EachSessionDrivesInItsOwnWorld) {
  const World base = testing::twoRooms();
  ChangeSet changes;
  WorldChange door;
  door.session = 1;
  door.kind = WorldChange::Kind::kDoor;
  door.from_m = {4.1, 2.9};
  door.to_m = {4.1, 4.3};
  changes.changes.push_back(door);
  SimulationParams p = shortSessions();
  p.max_scans = 0;
  p.waypoints = 6;
  // Session 0 crosses the doorway; in session 1 the robot stays in the room it starts in.
  const auto crosses = [](const SimulatedSession& s) {
    bool left = false, right = false;
    for (const core::Pose2& x : s.truth) {
      left = left || x.x() < 4.0;
      right = right || x.x() > 4.2;
    }
    return left && right;
  };
  int crossed = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    crossed += crosses(simulateSession(worldOfSession(base, changes, 0), 0, p, seed));
    EXPECT_FALSE(crosses(simulateSession(worldOfSession(base, changes, 1), 1, p, seed)));
  }
  EXPECT_GE(crossed, 2);
}

TEST(SessionSimulator, FollowsAGivenRouteInItsOwnWorld) {
  const World base = testing::twoRooms();
  const Route route = readRoute(testing::writeTemp(
      "route.yaml",
      "waypoints:\n  - [0.0, 1.0]\n  - [8.5, 2.0]  # the other room\n  - [0.0, 1.0]\n"));
  ASSERT_EQ(route.waypoints_m.size(), 3U);
  EXPECT_EQ(route.lines[1], 3U);
  SimulationParams p = shortSessions();
  p.max_scans = 0;
  const SimulatedSession s = simulateSession(base, 0, p, 1, &route);
  ASSERT_EQ(s.waypoints_m.size(), 3U);
  EXPECT_LT((s.truth.front().head<2>() - route.waypoints_m[0]).norm(), 0.1);
  double nearest = 1e9;
  for (const core::Pose2& x : s.truth) {
    nearest = std::min(nearest, (x.head<2>() - route.waypoints_m[1]).norm());
  }
  EXPECT_LT(nearest, 0.6);  // pure pursuit passes a waypoint within its lookahead
  EXPECT_LT((s.truth.back().head<2>() - route.waypoints_m[2]).norm(), 0.1);
  // A closed door cuts the route: the error names the route's file and the waypoint.
  ChangeSet changes;
  WorldChange door;
  door.kind = WorldChange::Kind::kDoor;
  door.from_m = {4.1, 2.9};
  door.to_m = {4.1, 4.3};
  changes.changes.push_back(door);
  try {
    simulateSession(worldOfSession(base, changes, 0), 0, p, 1, &route);
    ADD_FAILURE() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_EQ(e.source(), route.path);
    EXPECT_EQ(e.line(), 3U);
    EXPECT_NE(e.reason().find("waypoint 2 cannot be reached"), std::string::npos) << e.what();
  }
  // A waypoint inside the pillar moves to free space nearby; one far inside a block does not.
  const Route pillar =
      readRoute(testing::writeTemp("pillar.yaml", "waypoints: [[0.0, 1.0], [8.0, 5.0]]\n"));
  EXPECT_NO_THROW(simulateSession(base, 0, p, 1, &pillar));
  World walled = base;
  WorldChange block;
  block.center_m = {8.0, 5.0};
  block.size_m = {3.0, 3.0};
  applyChange(walled, block, base);
  EXPECT_THROW(simulateSession(walled, 0, p, 1, &pillar), core::InputError);
}

TEST(SessionSimulator, TheBundledRingRouteGoesRoundEveryDayOfTheFurniture) {
  const std::string dir = std::string(RRR_TEST_DATA_DIR) + "/../../worlds/intel_lab/";
  const World base = readWorld(dir + "intel_lab.yaml");
  const Route ring = readRoute(dir + "ring.yaml");
  const ChangeSet furniture = readChanges(dir + "furniture.yaml");
  SimulationParams p;
  p.max_scans = 0;
  for (int session = 0; session <= 3; ++session) {
    SCOPED_TRACE(session);
    const SimulatedSession s =
        simulateSession(worldOfSession(base, furniture, session), session, p, 1, &ring);
    // At the last waypoint (moved to its nearest traversable cell: within a few cm).
    EXPECT_LT((s.truth.back().head<2>() - ring.waypoints_m.back()).norm(), 0.2);
    EXPECT_GT(s.length_m, 70.0);  // once round: 74 m
    EXPECT_LT(s.length_m, 80.0);
  }
  // The doors cut the ring in session 2, as the route's file says.
  const ChangeSet doors = readChanges(dir + "doors.yaml");
  EXPECT_THROW(simulateSession(worldOfSession(base, doors, 2), 2, p, 1, &ring), core::InputError);
}

TEST(SessionSimulator, WritesALogTheProductReads) {
  const World w = testing::twoRooms();
  SimulationParams p = shortSessions();
  p.max_scans = 50;
  p.laser.laser_in_robot = {0.2, -0.05, 0.1};  // mounted off the robot's origin
  const SimulatedSession s = simulateSession(w, 0, p, 2);
  const std::string path = ::testing::TempDir() + "session.clf";
  writeCarmenLog(path, s.logRecords(1.0 / p.scan_rate_hz), p.laser, "test\nsecond line");
  const frontend::CarmenLog log = frontend::readCarmenLog(path);
  ASSERT_EQ(log.scans.size(), 50U);
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    const frontend::LaserRecord& r = log.scans[k];
    EXPECT_NEAR(r.timestamp, s.stamps[k], 1e-6);
    EXPECT_NEAR(r.angle_min, -M_PI / 2, 1e-6);
    EXPECT_NEAR(r.angle_increment, M_PI / 180, 1e-6);
    EXPECT_DOUBLE_EQ(r.max_range, p.laser.max_range_m);
    const core::Pose2 odom_error = core::between(s.odometry[k], r.odom_pose);
    EXPECT_LT(odom_error.cwiseAbs().maxCoeff(), 2e-6);  // written to the microunit
    const core::Pose2 mount_error = core::between(p.laser.laser_in_robot, r.laserInRobot());
    EXPECT_LT(mount_error.cwiseAbs().maxCoeff(), 1e-5);
    ASSERT_EQ(r.ranges.size(), 181U);
    for (std::size_t i = 0; i < r.ranges.size(); ++i) {
      EXPECT_NEAR(r.ranges[i], s.ranges[k][i], 6e-4);
    }
  }
}

}  // namespace
}  // namespace rrr_graphslam::sim
