#include "rrr_graphslam/sim/route.h"

#include "rrr_graphslam/sim/yaml_fields.h"

namespace rrr_graphslam::sim {

Route readRoute(const std::string& path) {
  Route route;
  route.path = path;
  const YamlDocument doc(path);
  const YamlEntry root = doc.root("a route ('waypoints:' and a list of [x, y] points)");
  root.expectOnly({"waypoints"});
  for (const YamlEntry::Point& p : root.points("waypoints", "waypoint")) {
    route.waypoints_m.push_back(p.xy);
    route.lines.push_back(p.line);
  }
  if (route.waypoints_m.size() < 2) {
    root.fail("waypoints", "needs at least 2 points (the start and a place to go)");
  }
  return route;
}

}  // namespace rrr_graphslam::sim
