// LaserSlam across runs: the snapshot a map file holds, and a new session continuing one.

#include <algorithm>
#include <deque>
#include <exception>
#include <map>
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

std::vector<int> LaserSlam::nodeSessions() const {
  std::vector<int> out(node_local_poses_.size(), 0);
  std::size_t session = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    while (session + 1 < sessions_.size() &&
           sessions_[session + 1].first_node <= static_cast<int>(k)) {
      ++session;
    }
    out[k] = static_cast<int>(session);
  }
  return out;
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
  const std::vector<int> session = nodeSessions();
  for (std::size_t k = 0; k < node_local_poses_.size(); ++k) {
    map.nodes.push_back(
        {session[k], node_timestamps_[k], node_local_poses_[k], map_poses[k], node_scans_[k]});
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
      const std::size_t index = candidate - 1;
      // Candidates RRR took from outside since the last scan are not adopted yet.
      out.source =
          index < candidate_source_.size() ? candidate_source_[index] : LoopSource::kExternal;
    }
    map.edges.push_back(std::move(out));
  }
  map.dense_factors = graph.denseFactors();
  map.submaps = finished_spans_;
  for (const auto& active : local_.submaps().active()) {
    map.submaps.push_back({active->anchorNode(), active->lastNode()});
  }
  map.lifelong = lifelong_;
  map.memory = memory_;
  return map;
}

namespace {

// Where RRR starts from for a loaded map's nodes: each session in its own odometry frame, as it
// was mapped. Nodes that marginal constraints (lifelong trimming) hold together with others
// (or dense factors) start where the map has them instead, as one rigid piece placed in the
// odometry frame of its first node: the pieces of a trimmed session, and sessions whose loops
// trimming folded into marginal constraints, are bound by trusted constraints that their own
// odometry frames would violate. In a trimmed map all of it moves rigidly so that the first node,
// which holds the gauge, starts at its map pose: the map frame stays where it was when trimming
// removed the nodes that defined it (an untrimmed map starts exactly as it was mapped).
std::vector<core::Pose2> startingPoses(const MapSnapshot& map) {
  const std::size_t n = map.nodes.size();
  core::UnionFind trusted(n);
  std::vector<char> has_marginal(n, 0);
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate) continue;
    trusted.unite(static_cast<std::size_t>(e.from), static_cast<std::size_t>(e.to));
  }
  for (const core::DenseFactor& f : map.dense_factors) {
    for (auto id : f.nodes) trusted.unite(static_cast<std::size_t>(f.nodes.front()), id);
  }
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kMarginal) {
      has_marginal[trusted.find(static_cast<std::size_t>(e.from))] = 1;
    }
  }
  for (const core::DenseFactor& f : map.dense_factors) {
    has_marginal[trusted.find(static_cast<std::size_t>(f.nodes.front()))] = 1;
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
  if (n > 0 && map.lifelong.trimmed_submaps > 0) {
    const core::Pose2 to_map = core::compose(map.nodes[0].map_pose, core::inverse(poses[0]));
    for (core::Pose2& pose : poses) pose = core::compose(to_map, pose);
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
  for (const core::DenseFactor& f : map.dense_factors) graph.addDenseFactor(f);
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
  slam->load(map, map.submaps.size());
  const int n = static_cast<int>(map.nodes.size());
  slam->sessions_.push_back(
      {session_name, 0.0, n, map.sessions.empty() ? 0 : map.sessions.back().number + 1});
  slam->session_first_submap_ = static_cast<int>(map.submaps.size());
  slam->session_first_scan_ = static_cast<std::size_t>(n);
  slam->local_ = LocalSlam(params.local, n, static_cast<int>(map.submaps.size()));
  return slam;
}

void LaserSlam::load(const MapSnapshot& map, std::size_t finished_submaps, bool continuing) {
  const int n = static_cast<int>(map.nodes.size());
  const bool localizing = mode_ == SessionMode::kLocalization;
  if (n > 0) {
    if (localizing) {
      rrr_ = rrr::OnlineRrr::fromPoseGraph(graphToLocalizeIn(map), params_.rrr, continuing);
      rrr_->fixNodes();
    } else {
      // The replay starts from the sessions' odometry frames; the saved map is where the
      // decisions that made it put the nodes, and the decision starts from it where it can.
      std::vector<core::Pose2> saved_map;
      saved_map.reserve(map.nodes.size());
      for (const MapSnapshot::Node& node : map.nodes) saved_map.push_back(node.map_pose);
      rrr_ = rrr::OnlineRrr::fromPoseGraph(graphToContinue(map), params_.rrr, continuing,
                                           std::move(saved_map));
    }
  }
  if (!continuing) rrr_->takeChanges();  // the loaded decisions are the starting point, not news
  // Each candidate's source, as RRR numbers them (by arrival: the newest end's node, then file
  // order): matched to the map's loop edges by their ends, in file order.
  std::map<std::pair<int, int>, std::deque<LoopSource>> sources;
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate)
      sources[{e.from, e.to}].push_back(e.source);
  }
  candidate_source_.clear();
  for (int k = 0; rrr_ && k < rrr_->numCandidates(); ++k) {
    const rrr::LoopCandidate& c = rrr_->candidate(k);
    std::deque<LoopSource>& queue = sources[{c.from, c.to}];
    candidate_source_.push_back(queue.empty() ? LoopSource::kUnknown : queue.front());
    if (!queue.empty()) queue.pop_front();
  }

  for (const MapSnapshot::Node& node : map.nodes) {
    const bool session_start = node_local_poses_.empty() ||
                               node.session != map.nodes[node_local_poses_.size() - 1].session;
    node_travel_.push_back(
        session_start
            ? 0.0
            : node_travel_.back() +
                  (node.local_pose.head<2>() - node_local_poses_.back().head<2>()).norm());
    node_local_poses_.push_back(node.local_pose);
    node_scans_.push_back(node.scan);
    node_timestamps_.push_back(node.timestamp);
    scan_node_.push_back(static_cast<int>(scan_node_.size()));
    scan_offset_.push_back(core::Pose2::Zero());
    scan_timestamps_.push_back(node.timestamp);
  }
  // The submaps, rebuilt from the scans that made them, in the order and at the poses they were
  // inserted; each on its own (the scans are only read), on the loop search's threads.
  const int submaps = static_cast<int>(finished_submaps);
  finished_.resize(finished_submaps);
  std::vector<std::exception_ptr> failed(finished_submaps);  // none leaves a parallel loop
#pragma omp parallel for schedule(dynamic) num_threads(params_.loops.threads) if (submaps > 1)
  for (int i = 0; i < submaps; ++i) {
    try {
      const MapSnapshot::Submap& span = map.submaps[static_cast<std::size_t>(i)];
      auto submap = std::make_shared<Submap>(
          i, span.first_node, map.nodes[static_cast<std::size_t>(span.first_node)].local_pose,
          params_.local.submap);
      for (int k = span.first_node; k <= span.last_node; ++k) {
        const auto& node = map.nodes[static_cast<std::size_t>(k)];
        submap->insert(*node.scan, node.local_pose, k);
      }
      submap->finish();
      finished_[static_cast<std::size_t>(i)] = std::move(submap);
    } catch (...) {
      failed[static_cast<std::size_t>(i)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : failed) {
    if (e) std::rethrow_exception(e);
  }
  if (n > 0) map_sensor_ = SensorSetup::of(*map.nodes.back().scan);  // check(): all have one
  finished_spans_.assign(map.submaps.begin(),
                         map.submaps.begin() + static_cast<std::ptrdiff_t>(finished_submaps));
  lifelong_ = map.lifelong;
  memory_ = map.memory;
  sessions_ = map.sessions;
  search_state_.resize(finished_submaps);
  stats_.nodes = n;
  stats_.submaps = stats_.finished_submaps = submaps;
}

LaserSlam::Checkpoint LaserSlam::checkpoint() const {
  if (mode_ == SessionMode::kLocalization) {
    throw std::logic_error("localization leaves the loaded map as it is: nothing to trim");
  }
  if (static_cast<int>(node_local_poses_.size()) <= sessions_.back().first_node) {
    throw std::logic_error("the current session has no node yet");
  }
  const auto first_scan = static_cast<std::ptrdiff_t>(session_first_scan_);
  return Checkpoint{snapshot(),
                    params_,
                    local_.checkpoint(),
                    sessions_,
                    session_first_submap_,
                    tied(),
                    tied_by_marginals_,
                    {scan_node_.begin() + first_scan, scan_node_.end()},
                    {scan_offset_.begin() + first_scan, scan_offset_.end()},
                    {scan_timestamps_.begin() + first_scan, scan_timestamps_.end()},
                    search_state_,
                    rival_search_state_,
                    stats_,
                    tie_,
                    map_sensor_,
                    relocalization_matches_,
                    relocalization_paused_until_,
                    apart_matches_,
                    apart_paused_until_,
                    session_points_,
                    {node_travel_.begin() + sessions_.back().first_node, node_travel_.end()}};
}

bool LaserSlam::trimsWhileMapping(bool tied, std::size_t sessions, const TrimParams& params) {
  return tied || (sessions == 1 && !params.keep_current_session);
}

bool LaserSlam::trimsWhileMapping(const TrimParams& params) const {
  return mode_ == SessionMode::kMapping && trimsWhileMapping(tied(), sessions_.size(), params);
}

LaserSlam::Trimmed LaserSlam::trimmed(const Checkpoint& c, const TrimParams& params,
                                      const TrimmingStrategy& strategy) {
  if (!trimsWhileMapping(c.tied, c.sessions.size(), params)) return {};
  // The submaps local SLAM still builds are never trimmed; the session's own older ones only
  // once it came back to them.
  TrimParams p = params;
  p.keep_recent_submaps = std::max(p.keep_recent_submaps, static_cast<int>(c.local.active.size()));
  p.revisit_gap_nodes = std::max(p.revisit_gap_nodes, c.params.loops.min_node_separation);
  TrimResult trim = trimMap(c.map, p, strategy, c.params.local.submap, NewestSession::kRunning);
  Trimmed out{nullptr, trim.report};
  if (trim.map.nodes.size() == c.map.nodes.size() &&
      trim.map.submaps.size() == c.map.submaps.size()) {
    return out;  // nothing left: the running map stays
  }
  const std::vector<int>& node_index = trim.node_index;
  const int old_first = c.sessions.back().first_node;
  const int old_nodes = static_cast<int>(c.map.nodes.size());
  const int old_submaps = static_cast<int>(c.map.submaps.size());
  // A node number of the checkpoint, renumbered after the nodes removed before it: a kept node's
  // new index, a removed one's (or one past the end's) that of the next kept node.
  std::vector<int> removed_before(static_cast<std::size_t>(old_nodes) + 1, 0);
  for (int k = 0; k < old_nodes; ++k) {
    removed_before[static_cast<std::size_t>(k) + 1] =
        removed_before[static_cast<std::size_t>(k)] + (node_index[static_cast<std::size_t>(k)] < 0);
  }
  auto renumbered = [&](int node) {
    return node - removed_before[static_cast<std::size_t>(std::clamp(node, 0, old_nodes))];
  };
  // Local SLAM's submaps and their nodes are the newest: kept, in one block that moves as one.
  const int active_first_submap = old_submaps - static_cast<int>(c.local.active.size());
  const int active_first_node =
      c.local.active.empty()
          ? old_nodes - 1
          : c.map.submaps[static_cast<std::size_t>(active_first_submap)].first_node;
  const int node_shift = removed_before[static_cast<std::size_t>(old_nodes)];
  const int submap_shift =
      old_submaps - static_cast<int>(trim.map.submaps.size());  // trimmed before the active ones
  for (int k = active_first_node; k < old_nodes; ++k) {
    if (node_index[static_cast<std::size_t>(k)] != k - node_shift) {
      throw std::logic_error("online trimming removed a node of local SLAM's submaps");
    }
  }
  for (int i = active_first_submap; i < old_submaps; ++i) {
    if (trim.submap_index[static_cast<std::size_t>(i)] != i - submap_shift) {
      throw std::logic_error("online trimming removed a submap local SLAM builds");
    }
  }

  auto slam = std::make_unique<LaserSlam>(c.params, c.sessions.back().name);
  const std::size_t finished = trim.map.submaps.size() - c.local.active.size();
  slam->load(trim.map, finished, true);
  const int first = trim.map.sessions.back().first_node;
  slam->session_first_submap_ = static_cast<int>(finished);
  for (int i = c.session_first_submap; i < old_submaps; ++i) {  // its first kept one
    const int to = trim.submap_index[static_cast<std::size_t>(i)];
    if (to >= 0) {
      slam->session_first_submap_ = to;
      break;
    }
  }
  slam->session_first_scan_ = static_cast<std::size_t>(first);
  // The current session's scans as they were, not one per node as load() has them. A scan of a
  // removed node rides from now on with the kept node of the session nearest along its path
  // (before or after it), at the pose the checkpoint's map gave it.
  slam->scan_node_.resize(slam->session_first_scan_);
  slam->scan_offset_.resize(slam->session_first_scan_);
  slam->scan_timestamps_.resize(slam->session_first_scan_);
  const auto session_nodes = static_cast<std::size_t>(old_nodes - old_first);
  auto travel = [&](int k) { return c.session_travel.at(static_cast<std::size_t>(k - old_first)); };
  std::vector<int> anchor(session_nodes, -1);               // old numbers
  for (int k = old_first, kept = -1; k < old_nodes; ++k) {  // the kept node before
    if (node_index[static_cast<std::size_t>(k)] >= 0) kept = k;
    anchor[static_cast<std::size_t>(k - old_first)] = kept;
  }
  for (int k = old_nodes - 1, kept = -1; k >= old_first; --k) {  // or the one after, if nearer
    if (node_index[static_cast<std::size_t>(k)] >= 0) kept = k;
    int& a = anchor[static_cast<std::size_t>(k - old_first)];
    if (a < 0 || (kept >= 0 && travel(kept) - travel(k) < travel(k) - travel(a))) a = kept;
  }
  for (std::size_t i = 0; i < c.scan_node.size(); ++i) {
    const int node = c.scan_node[i];
    const int to = anchor[static_cast<std::size_t>(node - old_first)];
    slam->scan_node_.push_back(node_index[static_cast<std::size_t>(to)]);
    slam->scan_offset_.push_back(
        to == node
            ? c.scan_offset[i]
            : core::compose(core::between(c.map.nodes[static_cast<std::size_t>(to)].map_pose,
                                          c.map.nodes[static_cast<std::size_t>(node)].map_pose),
                            c.scan_offset[i]));
  }
  slam->scan_timestamps_.insert(slam->scan_timestamps_.end(), c.scan_timestamps.begin(),
                                c.scan_timestamps.end());
  // The session's travel as it was measured, not across the gaps removed nodes leave.
  for (int k = old_first; k < old_nodes; ++k) {
    const int to = node_index[static_cast<std::size_t>(k)];
    if (to >= 0) slam->node_travel_.at(static_cast<std::size_t>(to)) = travel(k);
  }
  const MapSnapshot& map = trim.map;
  slam->local_ = LocalSlam::resume(c.local, node_shift, submap_shift,
                                   [&map](int k) -> const mrpt::obs::CObservation2DRangeScan& {
                                     return *map.nodes.at(static_cast<std::size_t>(k)).scan;
                                   });
  // Each submap's sampling and pauses, for the search around the session's estimate and around
  // its rival reading alike, carry over to its new number.
  auto carry = [&](const std::vector<SubmapSearchState>& from, std::vector<SubmapSearchState>& to) {
    for (std::size_t i = 0; i < from.size() && i < trim.submap_index.size(); ++i) {
      const int k = trim.submap_index[i];
      if (k < 0) continue;
      to.at(static_cast<std::size_t>(k)) = {renumbered(from[i].last_searched),
                                            renumbered(from[i].last_matched)};
    }
  };
  carry(c.search_state, slam->search_state_);
  if (!c.rival_search_state.empty()) {
    slam->rival_search_state_.resize(slam->search_state_.size());
    carry(c.rival_search_state, slam->rival_search_state_);
  }
  // The loops between the current session and the earlier ones, in arrival order: those of open
  // clusters all kept (they hold their submaps back); accepted ones of closed clusters may now be
  // part of marginal constraints, which tie the session for good.
  for (int i = 0; i < slam->rrr_->numCandidates(); ++i) slam->noteCrossing(i);
  // Accepted loops between the session and the map leave only folded into marginal constraints.
  auto acceptedCrossing = [](const MapSnapshot& m) {
    const int session_first = m.sessions.back().first_node;
    int count = 0;
    for (const MapSnapshot::Edge& e : m.edges) {
      count += e.kind == MapSnapshot::EdgeKind::kLoopCandidate &&
               e.verdict == rrr::Verdict::kAccepted &&
               (e.from < session_first) != (e.to < session_first);
    }
    return count;
  };
  slam->tied_by_marginals_ =
      c.tied_by_marginals || (c.tied && acceptedCrossing(trim.map) < acceptedCrossing(c.map));
  slam->stats_ = c.stats;
  slam->stats_.nodes = static_cast<int>(map.nodes.size());
  slam->stats_.submaps = slam->local_.submaps().numSubmaps();
  slam->stats_.finished_submaps = static_cast<int>(finished);
  slam->tie_ = c.tie;
  if (slam->tie_) slam->tie_->node = renumbered(slam->tie_->node);
  // No relocalization hint: it guides the searches until the session is tied, and a trim comes
  // only after (or in the map's first session, which has none).
  slam->map_sensor_ = c.map_sensor;
  slam->relocalization_matches_ = c.relocalization_matches;
  slam->relocalization_paused_until_ = renumbered(c.relocalization_paused_until);
  // During a relocalization rest the clusters joining the session to the map were closed when it
  // began (searchLoops); the replay above reopened them by the gap rule.
  if (slam->sessions_.size() > 1 &&
      slam->relocalization_paused_until_ > static_cast<int>(map.nodes.size()) - 1) {
    slam->rrr_->closeJoining(
        static_cast<rrr::OnlineRrr::NodeId>(slam->sessions_.back().first_node));
  }
  slam->apart_matches_ = c.apart_matches;
  slam->apart_paused_until_ = renumbered(c.apart_paused_until);
  slam->session_points_.clear();
  for (const KeptPoints& points : c.session_points) {
    if (node_index[static_cast<std::size_t>(points.node)] < 0) continue;
    slam->session_points_.push_back(points);
    slam->session_points_.back().node = node_index[static_cast<std::size_t>(points.node)];
  }
  out.slam = std::move(slam);
  return out;
}

}  // namespace rrr_graphslam::frontend
