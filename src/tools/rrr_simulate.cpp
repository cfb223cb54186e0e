// rrr_simulate WORLD.yaml --out DIR [--sessions N] [--changes CHANGES.yaml] [--seed S] [...]
// Simulated mapping sessions in a map_server world that changes between them: per session a
// CARMEN log (own odometry frame, own date), its ground-truth poses (TUM) and its true world
// (map_server). doc/simulation.md describes the formats.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "command_line.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/sim/carmen_writer.h"
#include "rrr_graphslam/sim/route.h"
#include "rrr_graphslam/sim/session_simulator.h"
#include "rrr_graphslam/sim/world.h"
#include "rrr_graphslam/sim/world_changes.h"
#include "tum_trajectory.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace sim = rrr_graphslam::sim;

const char* const kUsage =
    "usage: rrr_simulate WORLD.yaml --out DIR [--sessions N] [--changes CHANGES.yaml]\n"
    "                    [--seed S] [--waypoints N | --route ROUTE.yaml] [--max-scans N]\n"
    "                    [--scan-rate HZ]\n"
    "                    [--speed M_PER_S] [--clearance M] [--beams N]\n"
    "                    [--angle-increment-deg D] [--max-range M] [--range-stddev M]\n"
    "                    [--odometry-noise F,L,YT,YM] [--start-time S] [--session-gap S]\n"
    "  WORLD.yaml      a map_server world (YAML + PGM); unknown cells count as solid\n"
    "  --out           output folder (created); per session K (2 digits): session_K.clf,\n"
    "                  session_K_truth.txt, session_K_world.pgm + .yaml\n"
    "  --sessions      number of sessions (default 1)\n"
    "  --changes       boxes and doors that change between sessions (doc/simulation.md);\n"
    "                  repeat it to apply several change sets\n"
    "  --seed          seed of every random draw (default 1); a session depends only on the\n"
    "                  seed, its index and its world\n"
    "  --waypoints     random waypoints visited per session (default 8)\n"
    "  --route         visit these waypoints in order in every session instead\n"
    "                  ('waypoints: [[x, y], ...]', world frame; doc/simulation.md)\n"
    "  --max-scans     stop each session after N scans (default 0: at its last waypoint)\n"
    "  --scan-rate     scans per second (default 5)\n"
    "  --speed         top speed, m/s (default 0.4)\n"
    "  --clearance     m the robot's centre keeps from solid cells (default 0.35)\n"
    "  --beams         beams per scan (default 181, a SICK LMS 200 at 1 degree)\n"
    "  --angle-increment-deg  degrees between beams (default 1); the fan is centred ahead\n"
    "  --max-range     m; 'no return' reads this (default 30)\n"
    "  --range-stddev  m; Gaussian range noise (default 0.01)\n"
    "  --odometry-noise F,L,YT,YM  odometry drift: forward and lateral m per sqrt(m), yaw rad\n"
    "                  per sqrt(rad turned) and per sqrt(m) (default 0.02,0.01,0.02,0.005;\n"
    "                  0,0,0,0: exact odometry)\n"
    "  --start-time    Unix time of session 0's first scan (default 1700000000)\n"
    "  --session-gap   s between the starts of consecutive sessions (default 86400, a day)\n"
    "Prints 'key value' lines: world, sessions, seed, changes, then per session 'session K\n"
    "scans N length_m L duration_s D changes C odometry_drift_m E log PATH', scans, time.\n";

std::vector<double> numberList(const tools::CommandLine& cli, const std::string& option,
                               const std::string& text, std::size_t count) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    out.push_back(cli.number(option, item, 0.0, 10.0));
  }
  if (out.size() != count) {
    cli.fail(option + " needs " + std::to_string(count) + " comma-separated numbers, not '" + text +
             "'");
  }
  return out;
}

std::string sessionName(int k, int sessions) {
  const int digits = std::max(2, static_cast<int>(std::to_string(sessions - 1).size()));
  std::string number = std::to_string(k);
  return "session_" + std::string(static_cast<std::size_t>(digits) - number.size(), '0') + number;
}

// NAME.clf, NAME_truth.txt and NAME_world.{pgm,yaml} in `out_dir`, each written atomically.
void writeSession(const sim::SimulatedSession& s, const sim::World& world,
                  const sim::SimulationParams& params, const std::string& out_dir,
                  const std::string& name, const std::string& comment) {
  const std::string base = (std::filesystem::path(out_dir) / name).string();
  sim::writeCarmenLog(base + ".clf", s.logRecords(1.0 / params.scan_rate_hz), params.laser,
                      comment);
  tools::writeTumTrajectory(base + "_truth.txt", "rrr_simulate ground truth, world frame", s.stamps,
                            s.truth);
  sim::writeWorld(world, base + "_world");
}

}  // namespace

int main(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_simulate", kUsage);
  std::string world_path, route_path, out_dir;
  std::vector<std::string> changes_paths;
  int sessions = 1;
  std::uint64_t seed = 1;
  bool waypoints_given = false;
  sim::SimulationParams params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out") {
      out_dir = cli.value(i, a);
    } else if (a == "--changes") {
      changes_paths.push_back(cli.value(i, a));
    } else if (a == "--sessions") {
      sessions = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1000));
    } else if (a == "--seed") {
      seed = static_cast<std::uint64_t>(cli.integer(a, cli.value(i, a), 0, 4294967295.0));
    } else if (a == "--waypoints") {
      params.waypoints = static_cast<int>(cli.integer(a, cli.value(i, a), 1, 1e5));
      waypoints_given = true;
    } else if (a == "--route") {
      route_path = cli.value(i, a);
    } else if (a == "--max-scans") {
      params.max_scans = static_cast<std::size_t>(cli.integer(a, cli.value(i, a), 0, 1e8));
    } else if (a == "--scan-rate") {
      params.scan_rate_hz = cli.number(a, cli.value(i, a), 0.1, 1000.0);
    } else if (a == "--speed") {
      params.motion.max_speed_mps = cli.number(a, cli.value(i, a), 0.01, 10.0);
    } else if (a == "--clearance") {
      params.planner.clearance_m = cli.number(a, cli.value(i, a), 0.0, 10.0);
      params.planner.comfort_m = std::max(params.planner.comfort_m, params.planner.clearance_m);
    } else if (a == "--beams") {
      params.laser.beam_count = static_cast<int>(cli.integer(a, cli.value(i, a), 2, 100000));
    } else if (a == "--angle-increment-deg") {
      params.laser.angle_increment_rad = cli.number(a, cli.value(i, a), 1e-3, 180.0) * M_PI / 180;
    } else if (a == "--max-range") {
      params.laser.max_range_m = cli.number(a, cli.value(i, a), 0.1, 1000.0);
    } else if (a == "--range-stddev") {
      params.laser.range_stddev_m = cli.number(a, cli.value(i, a), 0.0, 10.0);
    } else if (a == "--odometry-noise") {
      const std::vector<double> v = numberList(cli, a, cli.value(i, a), 4);
      params.odometry = {v[0], v[1], v[2], v[3]};
    } else if (a == "--start-time") {
      params.start_time_s = cli.number(a, cli.value(i, a), 0.0, 1e10);
    } else if (a == "--session-gap") {
      params.session_gap_s = cli.number(a, cli.value(i, a), 0.0, 1e9);
    } else {
      cli.positional(a, world_path);
    }
  }
  if (world_path.empty()) cli.fail("no world given");
  if (out_dir.empty()) cli.fail("--out is required");
  if (waypoints_given && !route_path.empty())
    cli.fail("--waypoints and --route exclude each other");
  const double fov = (params.laser.beam_count - 1) * params.laser.angle_increment_rad;
  if (fov > 2 * M_PI + 1e-9) cli.fail("--beams x --angle-increment-deg exceeds 360 degrees");
  params.laser.angle_min_rad = -0.5 * fov;
  try {
    const auto start = core::Clock::now();
    const sim::World base = sim::readWorld(world_path);
    // Several change sets apply as one, in the order given.
    sim::ChangeSet changes;
    for (const std::string& path : changes_paths) {
      const sim::ChangeSet set = sim::readChanges(path);
      sim::validateChanges(set, base);
      changes.changes.insert(changes.changes.end(), set.changes.begin(), set.changes.end());
    }
    sim::validateOpenings(changes, base);
    sim::Route route;
    if (!route_path.empty()) route = sim::readRoute(route_path);
    std::size_t due = 0;
    for (const auto& c : changes.changes) due += c.session < sessions;
    std::printf("world          %s (%d x %d cells, %g m)\n", world_path.c_str(), base.width,
                base.height, base.resolution_m);
    std::printf("sessions       %d\nseed           %llu\n", sessions,
                static_cast<unsigned long long>(seed));
    std::printf("changes        %zu (%zu for later sessions)\n", due, changes.changes.size() - due);
    std::filesystem::create_directories(out_dir);
    const auto comment = [&](int k) {
      std::ostringstream text;
      text << "rrr_simulate session " << k << " of " << sessions << " in " << world_path
           << ", seed " << seed
           << "\nodometry in the session's own frame; ground truth: " << sessionName(k, sessions)
           << "_truth.txt";
      return text.str();
    };
    std::size_t scans = 0;
    for (int k = 0; k < sessions; ++k) {
      const sim::World world = sim::worldOfSession(base, changes, k);
      const sim::SimulatedSession s =
          sim::simulateSession(world, k, params, seed, route_path.empty() ? nullptr : &route);
      writeSession(s, world, params, out_dir, sessionName(k, sessions), comment(k));
      std::size_t session_changes = 0;
      for (const auto& c : changes.changes) session_changes += c.session == k;
      const core::Pose2 drift = core::between(core::between(s.odometry.front(), s.odometry.back()),
                                              core::between(s.truth.front(), s.truth.back()));
      std::printf(
          "session %d scans %zu length_m %.1f duration_s %.1f changes %zu odometry_drift_m %.2f "
          "log %s.clf\n",
          k, s.truth.size(), s.length_m, s.stamps.back() - s.stamps.front(), session_changes,
          drift.head<2>().norm(),
          (std::filesystem::path(out_dir) / sessionName(k, sessions)).string().c_str());
      scans += s.truth.size();
    }
    std::printf("scans          %zu\ntime           %.2f s\n", scans, core::secondsSince(start));
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_simulate: " << e.what() << "\n";
    return 1;
  }
}
