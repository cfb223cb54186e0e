// LaserSlam across runs: the snapshot a map file holds, and a new session continuing one.

#include <exception>
#include <stdexcept>
#include <string>

#include "rrr_graphslam/core/union_find.h"
#include "rrr_graphslam/frontend/laser_slam.h"

namespace rrr_graphslam::frontend {
namespace {

// The parameters a loaded map's submaps and scans depend on: with another value the rebuilt
// submaps would not be the ones the map was made of, or new scans would not match them.
constexpr const char* kFixedParams[] = {"submap_resolution", "scan_max_range"};

void checkContinuable(const MapSnapshot& map, const LaserSlamParams& params) {
  for (const char* name : kFixedParams) {
    std::string current;
    forEachSlamParam(params, [&](const core::ParamInfo& info, const auto& value) {
      if (std::string(info.name) == name) current = core::formatParam(value);
    });
    for (const auto& [saved_name, saved] : map.params) {
      if (saved_name == name && saved != current) {
        throw std::invalid_argument(
            std::string(name) + " is " + current + " here but the map was made with " + saved +
            ": its submaps cannot be continued (set " + name + " to " + saved + ")");
      }
    }
  }
}

}  // namespace

std::vector<std::pair<std::string, std::string>> LaserSlam::snapshotParams() const {
  std::vector<std::pair<std::string, std::string>> params;
  auto record = [&](const core::ParamInfo& info, const auto& value) {
    params.emplace_back(info.name, core::formatParam(value));
  };
  forEachSlamParam(params_, record);
  rrr::forEachParam(params_.rrr.rrr, record);
  return params;
}

MapSnapshot LaserSlam::snapshot() const {
  if (mode_ == SessionMode::kLocalization) {
    throw std::logic_error(
        "localization leaves the loaded map as it is: there is no new map to save");
  }
  if (node_local_poses_.empty()) {
    throw std::invalid_argument("the map has no nodes yet: nothing to save");
  }
  MapSnapshot map;
  map.params = snapshotParams();
  map.sessions = sessions_;
  // A session that ended before its first node leaves no trace.
  while (map.sessions.size() > 1 &&
         map.sessions.back().first_node >= static_cast<int>(node_local_poses_.size())) {
    map.sessions.pop_back();
  }
  const std::vector<core::Pose2> map_poses = rrr_->mapPoses();
  std::size_t session = 0;
  for (std::size_t k = 0; k < node_local_poses_.size(); ++k) {
    while (session + 1 < map.sessions.size() &&
           map.sessions[session + 1].first_node <= static_cast<int>(k)) {
      ++session;
    }
    map.nodes.push_back({static_cast<int>(session), node_timestamps_[k], node_local_poses_[k],
                         map_poses[k], node_scans_[k]});
  }
  const core::PoseGraph graph = rrr_->toPoseGraph();  // odometry, then candidates in arrival order
  const std::vector<rrr::DecisionRow> rows = rrr_->decisionRows();
  std::size_t candidate = 0;
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    const auto& edge = graph.edge(e);
    MapSnapshot::Edge out;
    out.from = static_cast<int>(edge.from);
    out.to = static_cast<int>(edge.to);
    out.measurement = graph.measurement(e);
    out.information = graph.information(e);
    if (edge.kind == core::EdgeKind::kOdometry) {
      out.kind = MapSnapshot::EdgeKind::kOdometry;
    } else if (edge.kind == core::EdgeKind::kMarginal) {
      out.kind = MapSnapshot::EdgeKind::kMarginal;
    } else {
      const rrr::DecisionRow& row = rows.at(candidate++);
      out.kind = MapSnapshot::EdgeKind::kLoopCandidate;
      out.verdict = row.verdict;
      out.cluster = row.cluster;
      out.reason = row.reason;
    }
    map.edges.push_back(std::move(out));
  }
  map.submaps = finished_spans_;
  for (const auto& active : local_.submaps().active()) {
    map.submaps.push_back({active->anchorNode(), active->lastNode()});
  }
  map.lifelong = lifelong_;
  return map;
}

namespace {

// Where RRR starts from for a loaded map's nodes: each session in its own odometry frame, as it
// was mapped. Nodes that marginal constraints (lifelong trimming) hold together with others
// start where the map has them instead, as one rigid piece placed in the odometry frame of its
// first node: the pieces of a trimmed session, and sessions whose loops trimming folded into
// marginal constraints, are bound by trusted constraints that their own odometry frames would
// violate.
std::vector<core::Pose2> startingPoses(const MapSnapshot& map) {
  const std::size_t n = map.nodes.size();
  core::UnionFind trusted(n);
  std::vector<char> has_marginal(n, 0);
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate) continue;
    trusted.unite(static_cast<std::size_t>(e.from), static_cast<std::size_t>(e.to));
  }
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kMarginal) {
      has_marginal[trusted.find(static_cast<std::size_t>(e.from))] = 1;
    }
  }
  std::vector<core::Pose2> poses(n);
  std::vector<int> first(n, -1);  // per component root: its first node
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t root = trusted.find(k);
    if (!has_marginal[root]) {
      poses[k] = map.nodes[k].local_pose;
      continue;
    }
    if (first[root] < 0) first[root] = static_cast<int>(k);
    const MapSnapshot::Node& anchor = map.nodes[static_cast<std::size_t>(first[root])];
    const core::Pose2 map_to_local =
        core::compose(anchor.local_pose, core::inverse(anchor.map_pose));
    poses[k] = core::compose(map_to_local, map.nodes[k].map_pose);
  }
  return poses;
}

// Mapping: the graph at startingPoses(), replayed into RRR, which decides it again.
core::PoseGraph graphToContinue(const MapSnapshot& map) {
  core::PoseGraph graph;
  const std::vector<core::Pose2> start = startingPoses(map);
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    graph.addNode(static_cast<core::PoseGraph::NodeId>(k), start[k]);
  }
  for (const MapSnapshot::Edge& e : map.edges) {
    graph.addEdge(static_cast<core::PoseGraph::NodeId>(e.from),
                  static_cast<core::PoseGraph::NodeId>(e.to), e.measurement, e.information,
                  toCoreKind(e.kind));
  }
  return graph;
}

// Localization: the nodes at their map poses, each joined to the next by the map's own relative
// pose, so that RRR's tests between two nodes of the map see where the map has them (the map's
// odometry between them would not: its loops moved them).
core::PoseGraph graphToLocalizeIn(const MapSnapshot& map) {
  const Eigen::Matrix3d rigid = Eigen::Vector3d(1e8, 1e8, 1e8).asDiagonal();
  core::PoseGraph graph;
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    graph.addNode(static_cast<core::PoseGraph::NodeId>(k), map.nodes[k].map_pose);
    if (k == 0) continue;
    graph.addEdge(static_cast<core::PoseGraph::NodeId>(k - 1),
                  static_cast<core::PoseGraph::NodeId>(k),
                  core::between(map.nodes[k - 1].map_pose, map.nodes[k].map_pose), rigid,
                  core::EdgeKind::kOdometry);
  }
  return graph;
}

}  // namespace

std::unique_ptr<LaserSlam> LaserSlam::fromMap(const MapSnapshot& map, const LaserSlamParams& params,
                                              const std::string& session_name, SessionMode mode) {
  map.check();
  checkContinuable(map, params);
  auto slam = std::make_unique<LaserSlam>(params, session_name);
  slam->mode_ = mode;
  const int n = static_cast<int>(map.nodes.size());
  const bool localizing = mode == SessionMode::kLocalization;
  if (n > 0) {
    slam->rrr_ = rrr::OnlineRrr::fromPoseGraph(
        localizing ? graphToLocalizeIn(map) : graphToContinue(map), slam->params_.rrr);
    if (localizing) slam->rrr_->fixNodes();
  }
  slam->rrr_->takeChanges();  // the loaded decisions are the starting point, not news

  for (const MapSnapshot::Node& node : map.nodes) {
    const bool session_start =
        slam->node_local_poses_.empty() ||
        node.session != map.nodes[slam->node_local_poses_.size() - 1].session;
    slam->node_travel_.push_back(
        session_start
            ? 0.0
            : slam->node_travel_.back() +
                  (node.local_pose.head<2>() - slam->node_local_poses_.back().head<2>()).norm());
    slam->node_local_poses_.push_back(node.local_pose);
    slam->node_scans_.push_back(node.scan);
    slam->node_timestamps_.push_back(node.timestamp);
    slam->scan_node_.push_back(static_cast<int>(slam->scan_node_.size()));
    slam->scan_offset_.push_back(core::Pose2::Zero());
    slam->scan_timestamps_.push_back(node.timestamp);
  }
  // The submaps, rebuilt from the scans that made them, in the order and at the poses they were
  // inserted; each on its own (the scans are only read), on the loop search's threads.
  const int submaps = static_cast<int>(map.submaps.size());
  slam->finished_.resize(map.submaps.size());
  std::vector<std::exception_ptr> failed(map.submaps.size());  // none leaves a parallel loop
#pragma omp parallel for schedule(dynamic) num_threads(params.loops.threads) if (submaps > 1)
  for (int i = 0; i < submaps; ++i) {
    try {
      const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(i)];
      auto submap = std::make_shared<Submap>(
          i, span.first_node, map.nodes[static_cast<std::size_t>(span.first_node)].local_pose,
          params.local.submap);
      for (int k = span.first_node; k <= span.last_node; ++k) {
        const auto& node = map.nodes[static_cast<std::size_t>(k)];
        submap->insert(*node.scan, node.local_pose, k);
      }
      submap->finish();
      slam->finished_[static_cast<std::size_t>(i)] = std::move(submap);
    } catch (...) {
      failed[static_cast<std::size_t>(i)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  if (n > 0) slam->map_sensor_ = SensorSetup::of(*map.nodes.back().scan);  // check(): all have one
  slam->finished_spans_ = map.submaps;
  slam->lifelong_ = map.lifelong;
  slam->sessions_ = map.sessions;
  slam->sessions_.push_back({session_name, 0.0, n});
  slam->session_first_submap_ = static_cast<int>(map.submaps.size());
  slam->session_first_scan_ = static_cast<std::size_t>(n);
  slam->search_state_.resize(map.submaps.size());
  slam->local_ = LocalSlam(params.local, n, static_cast<int>(map.submaps.size()));
  slam->stats_.nodes = n;
  slam->stats_.submaps = slam->stats_.finished_submaps = static_cast<int>(map.submaps.size());
  return slam;
}

}  // namespace rrr_graphslam::frontend
