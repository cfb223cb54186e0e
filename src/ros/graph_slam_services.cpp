// The node's services (~save, ~load, ~reset, ~optimize, ~finish): each runs in the worker thread
// in turn with the input (runInWorker), so it sees a consistent graph and never races RRR.

#include <chrono>
#include <cstdint>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/ros/graph_slam_ros.h"
#include "rrr_graphslam/rrr/decisions_io.h"

namespace rrr_graphslam::ros_adapter {

using core::secondsSince;

namespace {

// "map.g2o" -> "map.decisions.tsv" (also for .graph, .toro and their .gz).
std::string defaultDecisionsPath(std::string path) {
  for (const char* ext : {".gz", ".g2o", ".graph", ".toro"}) {
    const std::string e = ext;
    if (path.size() > e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) {
      path.resize(path.size() - e.size());
    }
  }
  return path + ".decisions.tsv";
}

void logServiceResult(const char* service, bool success, const std::string& message) {
  if (success) {
    ROS_INFO("%s: %s", service, message.c_str());
  } else {
    ROS_ERROR("%s failed: %s", service, message.c_str());
  }
}

}  // namespace

void GraphSlamRos::replaceGraph(std::unique_ptr<rrr::OnlineRrr> replacement) {
  if (slam_) {
    startSlam();  // a fresh front end (its graph holds no scans to go on from a loaded one)
  } else {
    graph_ = std::move(replacement);
    graph_->setCancelFlag(&cancel_);
  }
  owner_ = Owner::kNone;
  keyframes_.reset();
  last_keyframe_odom_.reset();
  last_keyframe_covariance_.reset();
  last_odom_stamp_ = ros::Time();
  node_stamps_.assign(static_cast<std::size_t>(graph().numNodes()), ros::Time::now());
  dirty_ = true;
  publishChanges();
}

// ---- Services ----------------------------------------------------------------------------------

bool GraphSlamRos::save(SaveGraph::Request& req, SaveGraph::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (req.path.empty()) throw std::invalid_argument("path is empty");
        const std::string decisions =
            req.decisions_path.empty() ? defaultDecisionsPath(req.path) : req.decisions_path;
        // One set: every file is written to a temporary before any replaces its path, so a
        // failure (or a kill) while writing leaves the previous save whole.
        core::AtomicFileSet files;
        const core::PoseGraph input = graph().toPoseGraph();
        files.add(req.path, [&](std::ostream& out) {
          core::writePoseGraph(input, out, core::formatFromPath(req.path));
        });
        files.add(decisions,
                  [&](std::ostream& out) { rrr::writeDecisions(out, graph().decisionRows()); });
        if (!req.optimized_path.empty()) {
          const core::PoseGraph optimized = graph().optimizedPoseGraph();
          files.add(req.optimized_path, [&](std::ostream& out) {
            core::writePoseGraph(optimized, out, core::formatFromPath(req.optimized_path));
          });
        }
        std::string written;
        for (const std::string& path : files.commit()) {
          written += (written.empty() ? "" : ", ") + path;
        }
        return "saved " + std::to_string(graph().numNodes()) + " nodes and " +
               std::to_string(graph().numCandidates()) + " candidates to " + written;
      },
      res.message);
  logServiceResult("~save", res.success, res.message);
  return true;
}

bool GraphSlamRos::load(LoadGraph::Request& req, LoadGraph::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (slam_) {
          throw std::invalid_argument(
              "~load is not available in slam mode: a saved graph holds no scans to match new "
              "ones against");
        }
        core::GraphReadOptions options;
        options.allow_disconnected = true;
        core::PoseGraph loaded = core::readPoseGraph(req.path, options);
        // g2o has no edge kinds: the decisions ~save wrote beside the graph say which edges are
        // loop candidates (a loop between id-consecutive nodes of two sessions stays a loop).
        const std::string decisions = defaultDecisionsPath(req.path);
        const bool with_decisions = std::ifstream(decisions).good();
        if (with_decisions) rrr::markCandidates(rrr::readDecisions(decisions), decisions, loaded);
        // The messages carry node ids as uint32: a larger one would be reported as another.
        for (const core::PoseGraph::NodeId id : loaded.nodeIds()) {
          if (id > std::numeric_limits<std::uint32_t>::max()) {
            throw std::invalid_argument(req.path + ": node id " + std::to_string(id) +
                                        " does not fit the uint32 ids of the node's messages");
          }
        }
        replaceGraph(rrr::OnlineRrr::fromPoseGraph(loaded, params_.rrr));
        const rrr::OnlineRrrStatus s = graph().status();
        return "loaded " + std::to_string(s.nodes) + " nodes (" + std::to_string(s.sessions) +
               " sessions) and " + std::to_string(s.candidates) + " candidates from " + req.path +
               (with_decisions ? " (edge kinds from " + decisions + ")" : std::string()) + ": " +
               std::to_string(s.accepted) + " accepted, " + std::to_string(s.rejected) +
               " rejected";
      },
      res.message);
  logServiceResult("~load", res.success, res.message);
  return true;
}

bool GraphSlamRos::saveMap(SaveMap::Request& req, SaveMap::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (!slam_) throw std::invalid_argument("~save_map needs slam mode (input_mode scan)");
        if (req.path.empty()) throw std::invalid_argument("path is empty");
        if (slam_->mode() == frontend::SessionMode::kLocalization) {
          throw std::invalid_argument(
              "mode is localization: the loaded map stays as it is, there is no new map to save");
        }
        const auto start = std::chrono::steady_clock::now();
        frontend::MapSnapshot map = slam_->snapshot();
        std::string trimmed;
        if (params_.lifelong) {
          frontend::TrimResult result =
              frontend::trimMap(map, params_.trim, params_.slam.local.submap);
          const frontend::TrimReport& r = result.report;
          trimmed = " (lifelong: trimmed " + std::to_string(r.trimmed_submaps) +
                    " submaps, marginalized " + std::to_string(r.removedNodes()) + " nodes into " +
                    std::to_string(r.marginalEdges()) + " marginal edges" +
                    (r.dense_factors_kept > 0
                         ? ", " + std::to_string(r.dense_factors_kept) + " dense factors kept"
                         : std::string()) +
                    ")";
          map = std::move(result.map);
        }
        frontend::writeMapFile(map, req.path);
        return "saved " + std::to_string(map.sessions.size()) + " sessions, " +
               std::to_string(map.nodes.size()) + " nodes and " +
               std::to_string(map.submaps.size()) + " submaps to " + req.path + " in " +
               std::to_string(secondsSince(start)) + " s" + trimmed;
      },
      res.message);
  logServiceResult("~save_map", res.success, res.message);
  return true;
}

bool GraphSlamRos::loadMap(LoadMap::Request& req, LoadMap::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (!slam_) throw std::invalid_argument("~load_map needs slam mode (input_mode scan)");
        const auto start = std::chrono::steady_clock::now();
        const frontend::MapSnapshot map = frontend::readMapFile(req.path);
        try {
          startSlam(&map);  // replaces the running map only once the loaded one is built
        } catch (const std::exception& e) {
          throw std::invalid_argument(req.path + ": " + e.what());
        }
        owner_ = Owner::kNone;
        dirty_ = true;
        map_dirty_ = true;
        publishChanges();
        return "loaded " + std::to_string(map.sessions.size()) + " sessions, " +
               std::to_string(map.nodes.size()) + " nodes and " +
               std::to_string(map.submaps.size()) + " submaps from " + req.path + " in " +
               std::to_string(secondsSince(start)) + " s; " +
               (params_.mode == "localization"
                    ? std::string("the next scans are localized in it")
                    : "the next scans start session " + std::to_string(map.sessions.size()));
      },
      res.message);
  logServiceResult("~load_map", res.success, res.message);
  return true;
}

bool GraphSlamRos::reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  // Whatever the worker is deciding now belongs to the graph being cleared: cut it short.
  cancel_ = true;
  res.success = runInWorker(
      [&]() -> std::string {
        cancel_ = false;
        replaceGraph(std::make_unique<rrr::OnlineRrr>(params_.rrr));
        received_ = processed_ = malformed_ = ignored_ = 0;
        decisions_published_ = 0;
        return "graph cleared";
      },
      res.message);
  return true;
}

bool GraphSlamRos::optimize(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        const auto start = std::chrono::steady_clock::now();
        if (trimmer_) trimmer_->drop();  // made before this decision: it would undo it
        graph().decideClosedFromScratch();
        map_dirty_ = map_dirty_ || slam_ != nullptr;  // the poses move, verdicts or not
        publishChanges();
        dirty_ = true;
        const rrr::OnlineRrrStatus s = graph().status();
        return "closed clusters decided again in " + std::to_string(secondsSince(start)) +
               " s: " + std::to_string(s.accepted) + " accepted, " + std::to_string(s.rejected) +
               " rejected, " + std::to_string(s.pending) + " pending";
      },
      res.message);
  return true;
}

bool GraphSlamRos::finish(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (slam_) {
          if (trimmer_) trimmer_->drop();
          slam_->finish();
          map_dirty_ = true;  // the decision from scratch moves the poses, verdicts or not
          offerMap();
        } else {
          graph().finish();
        }
        publishChanges();
        dirty_ = true;
        const rrr::OnlineRrrStatus s = graph().status();
        return "every cluster closed and decided: " + std::to_string(s.accepted) + " accepted, " +
               std::to_string(s.rejected) + " rejected";
      },
      res.message);
  return true;
}

}  // namespace rrr_graphslam::ros_adapter
