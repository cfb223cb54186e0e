// Route files: errors that name the file, the line and the waypoint. (Sessions that follow a
// route: test_session_simulator.cpp.)

#include <gtest/gtest.h>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/route.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

using testing::writeTemp;

TEST(Route, ReadsWaypointsWithTheirLines) {
  const Route route =
      readRoute(writeTemp("route.yaml", "# a route\nwaypoints:\n  - [0, 1.5]\n  - [-2, 3]\n"));
  ASSERT_EQ(route.waypoints_m.size(), 2U);
  EXPECT_EQ(route.waypoints_m[1], Eigen::Vector2d(-2.0, 3.0));
  EXPECT_EQ(route.lines, (std::vector<std::size_t>{3, 4}));
}

struct BadRoute {
  std::string text;
  std::size_t line;
  std::string message;
};

TEST(Route, BadRoutesNameFileLineAndWaypoint) {
  const std::vector<BadRoute> cases = {
      {"waypoints:\n  - [0, 1]\n  - [2]\n", 3, "waypoint 2 must be a list of 2 numbers"},
      {"waypoints:\n  - [0, 1]\n  - [2, inf]\n", 3, "waypoint 2 element 2 is not a finite"},
      {"waypoints: [[0, 1]]\n", 1, "'waypoints' needs at least 2 points"},
      {"points: [[0, 1], [1, 1]]\n", 1, "'points' is not a known field"},
  };
  for (const BadRoute& c : cases) {
    SCOPED_TRACE(c.message);
    const std::string path = writeTemp("bad_route.yaml", c.text);
    try {
      readRoute(path);
      ADD_FAILURE() << "no error";
    } catch (const core::InputError& e) {
      EXPECT_EQ(e.source(), path);
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(e.reason().find(c.message), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace rrr_graphslam::sim
