#include "rrr_graphslam/sim/session_simulator.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/clearance_map.h"

namespace rrr_graphslam::sim {
namespace {

// Independent streams per session and purpose, so that one purpose's draws never shift another's.
enum class Stream : std::uint64_t { kRoute = 1, kOdometry = 2, kLaser = 3 };

std::mt19937_64 makeRng(std::uint64_t seed, int session, Stream stream) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(session), static_cast<std::uint32_t>(stream)};
  return std::mt19937_64(seq);
}

template <class T>
const T& pick(const std::vector<T>& items, std::mt19937_64& rng) {
  std::uniform_int_distribution<std::size_t> index(0, items.size() - 1);
  return items[index(rng)];
}

// A start cell in a large connected part of the free space (not a closed-off pocket) and the
// cells reachable from it.
std::vector<Eigen::Vector2i> startComponent(const GridPlanner& planner, const ClearanceMap& map,
                                            std::mt19937_64& rng, Eigen::Vector2i& start) {
  std::vector<Eigen::Vector2i> traversable;
  for (int cy = 0; cy < map.height(); ++cy) {
    for (int cx = 0; cx < map.width(); ++cx) {
      if (planner.traversable(cx, cy)) traversable.emplace_back(cx, cy);
    }
  }
  if (traversable.empty()) {
    throw std::runtime_error("the world has no free cell with the planner's clearance");
  }
  std::vector<Eigen::Vector2i> best;
  for (int attempt = 0; attempt < 20; ++attempt) {
    const Eigen::Vector2i candidate = pick(traversable, rng);
    std::vector<Eigen::Vector2i> component = planner.reachable(candidate);
    if (component.size() > best.size()) {
      best = std::move(component);
      start = candidate;
    }
    if (4 * best.size() >= traversable.size()) break;
  }
  return best;
}

// The traversable cell nearest to `p_m` within `radius_m`, if any.
std::optional<Eigen::Vector2i> nearestTraversable(const World& world, const GridPlanner& planner,
                                                  const Eigen::Vector2d& p_m, double radius_m) {
  const Eigen::Vector2i c = world.cellOf(p_m);
  const int r = static_cast<int>(std::ceil(radius_m / world.resolution_m));
  std::optional<Eigen::Vector2i> best;
  double best_d = radius_m;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      if (!planner.traversable(c.x() + dx, c.y() + dy)) continue;
      const double d = (world.centerOf(c.x() + dx, c.y() + dy) - p_m).norm();
      if (d <= best_d) {
        best_d = d;
        best = Eigen::Vector2i(c.x() + dx, c.y() + dy);
      }
    }
  }
  return best;
}

// The cells of the route's waypoints in this world.
std::vector<Eigen::Vector2i> routeCells(const World& world, const GridPlanner& planner,
                                        const Route& route, int session) {
  std::vector<Eigen::Vector2i> cells;
  for (std::size_t k = 0; k < route.waypoints_m.size(); ++k) {
    const auto cell = nearestTraversable(world, planner, route.waypoints_m[k], 1.0);
    if (!cell) {
      throw core::InputError(route.path, route.lines[k],
                             "waypoint " + std::to_string(k + 1) +
                                 " has no cell with the planner's clearance within 1 m in the "
                                 "world of session " +
                                 std::to_string(session));
    }
    cells.push_back(*cell);
  }
  return cells;
}

}  // namespace

std::vector<LogRecord> SimulatedSession::logRecords(double period_s) const {
  std::vector<LogRecord> records(stamps.size());
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    LogRecord& r = records[k];
    r.timestamp = stamps[k];
    r.odom_pose = odometry[k];
    r.ranges = ranges[k];
    if (k > 0) {
      const core::Pose2 step = core::between(odometry[k - 1], odometry[k]);
      r.speed_mps = step.head<2>().norm() / period_s;
      r.turn_rate_radps = step.z() / period_s;
    }
  }
  return records;
}

SimulatedSession simulateSession(const World& world, int index, const SimulationParams& params,
                                 std::uint64_t seed, const Route* route) {
  if (!(params.scan_rate_hz > 0.0)) throw std::invalid_argument("scan_rate_hz must be positive");
  const double period_s = 1.0 / params.scan_rate_hz;
  const ClearanceMap clearance(world);
  const GridPlanner planner(clearance, params.planner);
  std::mt19937_64 route_rng = makeRng(seed, index, Stream::kRoute);

  SimulatedSession session;
  session.index = index;
  // The start and the waypoints: the route's, or random cells of the start's component.
  std::vector<Eigen::Vector2i> goals;
  Eigen::Vector2i at;
  if (route != nullptr) {
    goals = routeCells(world, planner, *route, index);
    at = goals.front();
    goals.erase(goals.begin());
  } else {
    const std::vector<Eigen::Vector2i> component =
        startComponent(planner, clearance, route_rng, at);
    Eigen::Vector2i previous = at;
    for (int w = 0; w < params.waypoints; ++w) {
      Eigen::Vector2i goal = pick(component, route_rng);
      for (int attempt = 0; attempt < 100; ++attempt) {
        const double d = world.resolution_m * (goal - previous).cast<double>().norm();
        if (d >= params.min_waypoint_separation_m) break;
        goal = pick(component, route_rng);
      }
      if (goal == previous) continue;
      goals.push_back(goal);
      previous = goal;
    }
  }
  session.waypoints_m.push_back(world.centerOf(at.x(), at.y()));
  std::vector<Eigen::Vector2d> path{session.waypoints_m.front()};
  for (std::size_t w = 0; w < goals.size(); ++w) {
    const Eigen::Vector2i& goal = goals[w];
    const auto cells = planner.plan(at, goal);
    if (!cells) {
      // Random waypoints share the start's component: only a route's can be cut off.
      throw core::InputError(route->path, route->lines[w + 1],
                             "waypoint " + std::to_string(w + 2) +
                                 " cannot be reached from the one before it in the world of "
                                 "session " +
                                 std::to_string(index));
    }
    for (std::size_t k = 1; k < cells->size(); ++k) {
      path.push_back(world.centerOf((*cells)[k].x(), (*cells)[k].y()));
    }
    session.waypoints_m.push_back(world.centerOf(goal.x(), goal.y()));
    at = goal;
  }

  double path_length = 0.0;
  for (std::size_t k = 1; k < path.size(); ++k) path_length += (path[k] - path[k - 1]).norm();
  // Enough samples for the whole path at a fifth of the top speed; fewer if max_scans says so.
  std::size_t max_samples = static_cast<std::size_t>(
      5.0 * path_length / (params.motion.max_speed_mps * period_s) + 1000.0);
  if (params.max_scans > 0) max_samples = std::min(max_samples, params.max_scans);
  const double start_yaw = std::uniform_real_distribution<double>(-M_PI, M_PI)(route_rng);
  session.truth = followPath(path, core::Pose2(path[0].x(), path[0].y(), start_yaw), params.motion,
                             period_s, max_samples);
  for (std::size_t k = 1; k < session.truth.size(); ++k) {
    session.length_m += (session.truth[k].head<2>() - session.truth[k - 1].head<2>()).norm();
  }

  const double t0 = params.start_time_s + index * params.session_gap_s;
  for (std::size_t k = 0; k < session.truth.size(); ++k) {
    session.stamps.push_back(t0 + static_cast<double>(k) * period_s);
  }

  std::mt19937_64 odometry_rng = makeRng(seed, index, Stream::kOdometry);
  std::uniform_real_distribution<double> offset(-params.odom_start_range_m,
                                                params.odom_start_range_m);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI);
  const double ox = offset(odometry_rng), oy = offset(odometry_rng);
  const core::Pose2 odom_start(ox, oy, yaw(odometry_rng));
  session.odometry = simulateOdometry(session.truth, odom_start, params.odometry, odometry_rng);

  std::mt19937_64 laser_rng = makeRng(seed, index, Stream::kLaser);
  const LaserSimulator laser(world, params.laser);
  session.ranges.reserve(session.truth.size());
  for (const core::Pose2& x : session.truth) session.ranges.push_back(laser.scan(x, &laser_rng));
  return session;
}

}  // namespace rrr_graphslam::sim
