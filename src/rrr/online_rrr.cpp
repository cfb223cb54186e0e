#include "rrr_graphslam/rrr/online_rrr.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/rrr/replay_plan.h"

namespace rrr_graphslam::rrr {
namespace {

std::string id(const char* field, OnlineRrr::NodeId value) {
  return std::string(field) + " " + std::to_string(value);
}

void checkConstraint(const core::Pose2& measurement, const Eigen::Matrix3d& information) {
  if (const std::string p = core::poseProblem(measurement); !p.empty()) {
    throw std::invalid_argument("measurement: " + p);
  }
  if (const std::string p = core::informationProblem(information); !p.empty()) {
    throw std::invalid_argument("information: " + p);
  }
}

bool sameMeasurement(const core::Pose2& a, const core::Pose2& b) {
  return (a - b).cwiseAbs().maxCoeff() <= 1e-12 * (1.0 + a.cwiseAbs().maxCoeff());
}

}  // namespace

OnlineRrr::OnlineRrr(const OnlineRrrParams& params)
    : params_(params), graph_(params.rrr.optimizer) {
  validate(params_);
  decider_ = makeOnlineDecider(graph_, params_.verifier, params_.rrr, params_.rrr.cluster_gap);
}

void validate(const OnlineRrrParams& params) {
  validate(params.rrr);
  if (params.rrr.cluster_gap <= 0) {
    throw std::invalid_argument(
        "cluster_gap = " + std::to_string(params.rrr.cluster_gap) +
        " is out of range online: must be a positive number of nodes (online the loop candidates "
        "arrive one by one, so it cannot be derived from them)");
  }
  validate(params.verifier);
  if (params.max_waiting_candidates < 0) {
    throw std::invalid_argument(
        "max_waiting_candidates = " + std::to_string(params.max_waiting_candidates) +
        " is out of range: must not be negative");
  }
}

int OnlineRrr::indexOf(NodeId node) const {
  const auto& ids = graph_.nodeIds();
  const auto it = std::lower_bound(ids.begin(), ids.end(), node);
  return it != ids.end() && *it == node ? static_cast<int>(it - ids.begin()) : -1;
}

void OnlineRrr::fixNodes() {
  if (numCandidates() > 0) {
    throw std::logic_error("OnlineRrr::fixNodes: call it before the first loop candidate");
  }
  core::Optimizer& opt = graph_.optimizer();
  opt.setPoses(graph_.initialPoses());
  for (int k = 0; k < numNodes(); ++k) opt.setFixed(k, true);
}

int OnlineRrr::appendNode(NodeId node, const core::Pose2& odom_pose) {
  return graph_.addNode(node, odom_pose);
}

void OnlineRrr::startSession(NodeId node, const core::Pose2& odom_pose) {
  if (!empty() && node <= nodeIds().back()) {
    throw std::invalid_argument(id("node id", node) + " is not newer than the newest node " +
                                std::to_string(nodeIds().back()));
  }
  if (const std::string p = core::poseProblem(odom_pose); !p.empty()) {
    throw std::invalid_argument("pose: " + p);
  }
  const int k = appendNode(node, odom_pose);
  if (decider_->advanceTo(k)) collectChanges();
  admitWaitingCandidates();
}

void OnlineRrr::addOdometry(NodeId from, NodeId to, const core::Pose2& measurement,
                            const Eigen::Matrix3d& information) {
  checkConstraint(measurement, information);
  const bool new_session = empty() || from > nodeIds().back();
  if (!new_session && from != nodeIds().back()) {
    throw std::invalid_argument(id("from_id", from) + " is not the newest node " +
                                std::to_string(nodeIds().back()) +
                                ": sequential edges extend the newest node");
  }
  if (to != from + 1) {
    throw std::invalid_argument(id("to_id", to) + " does not follow " + id("from_id", from) +
                                ": sequential edges join consecutive ids");
  }
  if (new_session) startSession(from, core::Pose2::Zero());
  const int k = appendNode(to, core::compose(odomPoses().back(), measurement));
  graph_.addOdometry(k - 1, k, measurement, information);
  odometry_.push_back({k - 1, k, measurement, information});
  if (decider_->advanceTo(k)) collectChanges();
  admitWaitingCandidates();
}

void OnlineRrr::addMarginal(NodeId from, NodeId to, const core::Pose2& measurement,
                            const Eigen::Matrix3d& information) {
  checkConstraint(measurement, information);
  const int a = indexOf(from), b = indexOf(to);
  if (a < 0) throw std::invalid_argument(id("from_id", from) + " is not a node");
  if (b < 0) throw std::invalid_argument(id("to_id", to) + " is not a node");
  if (a == b) throw std::invalid_argument(id("from_id", from) + " equals to_id");
  graph_.addMarginal(a, b, measurement, information);
}

void OnlineRrr::addDenseFactor(const core::DenseFactor& factor) {
  const std::string problem = core::denseFactorProblem(factor);
  if (!problem.empty()) throw std::invalid_argument("dense factor: " + problem);
  std::vector<int> nodes;
  for (NodeId n : factor.nodes) {
    const int a = indexOf(n);
    if (a < 0) throw std::invalid_argument("dense factor: " + id("node", n) + " is not a node");
    nodes.push_back(a);
  }
  graph_.addDenseFactor(nodes, factor);
}

OnlineRrr::CandidateStatus OnlineRrr::addCandidate(NodeId from, NodeId to,
                                                   const core::Pose2& measurement,
                                                   const Eigen::Matrix3d& information) {
  checkConstraint(measurement, information);
  if (from == to) throw std::invalid_argument(id("from_id", from) + " equals to_id");
  const bool from_arrived = !empty() && from <= nodeIds().back();
  const bool to_arrived = !empty() && to <= nodeIds().back();
  const int a = indexOf(from), b = indexOf(to);
  if (from_arrived && a < 0) throw std::invalid_argument(id("from_id", from) + " is not a node");
  if (to_arrived && b < 0) throw std::invalid_argument(id("to_id", to) + " is not a node");
  if (a >= 0 && b >= 0 && std::abs(a - b) == 1 && odometryBefore(std::max(a, b))) {
    throw std::invalid_argument(id("from_id", from) + " and " + id("to_id", to) +
                                " are consecutive nodes joined by odometry, not a loop");
  }
  const auto known = candidates_by_ends_.find({from, to});
  const bool duplicate =
      (known != candidates_by_ends_.end() &&
       std::any_of(
           known->second.begin(), known->second.end(),
           [&](int k) { return sameMeasurement(candidate(k).measurement, measurement); })) ||
      std::any_of(waiting_.begin(), waiting_.end(), [&](const Waiting& w) {
        return w.from == from && w.to == to && sameMeasurement(w.measurement, measurement);
      });
  if (duplicate) {
    throw std::invalid_argument("duplicate candidate: " + id("from_id", from) + ", " +
                                id("to_id", to) + " with the same measurement arrived before");
  }
  if (a < 0 || b < 0) {
    if (static_cast<int>(waiting_.size()) >= params_.max_waiting_candidates) {
      throw std::invalid_argument(
          std::to_string(waiting_.size()) + " candidates already wait for nodes newer than " +
          (empty() ? std::string("none") : std::to_string(nodeIds().back())) + "; " +
          id(a < 0 ? "from_id" : "to_id", a < 0 ? from : to) + " has not arrived");
    }
    waiting_.push_back({from, to, measurement, information});
    return CandidateStatus::kWaiting;
  }
  insertCandidate(a, b, measurement, information);
  return CandidateStatus::kAdded;
}

void OnlineRrr::insertCandidate(int from, int to, const core::Pose2& measurement,
                                const Eigen::Matrix3d& information) {
  const int k = graph_.addCandidate(from, to, measurement, information,
                                    static_cast<std::size_t>(numCandidates()));
  reported_.push_back(Verdict::kPending);
  const NodeId from_id = nodeIds()[static_cast<std::size_t>(from)];
  const NodeId to_id = nodeIds()[static_cast<std::size_t>(to)];
  candidates_by_ends_[{from_id, to_id}].push_back(k);
  changes_.push_back({k, from_id, to_id, -1, Verdict::kPending, Verdict::kPending,
                      "candidate received; its cluster is open"});
  if (decider_->addCandidate(k)) collectChanges();
}

void OnlineRrr::admitWaitingCandidates() {
  const NodeId newest = nodeIds().back();
  std::deque<Waiting> still_waiting;
  for (const Waiting& w : waiting_) {
    if (w.from > newest || w.to > newest) {
      still_waiting.push_back(w);
      continue;
    }
    const int a = indexOf(w.from), b = indexOf(w.to);
    if (a < 0 || b < 0) {
      dropped_.push_back("loop candidate " + std::to_string(w.from) + " -> " +
                         std::to_string(w.to) +
                         " dropped: " + id(a < 0 ? "from_id" : "to_id", a < 0 ? w.from : w.to) +
                         " never arrived (node ids jumped past it)");
      continue;
    }
    insertCandidate(a, b, w.measurement, w.information);
  }
  waiting_.swap(still_waiting);
}

void OnlineRrr::closeJoining(NodeId session_first) {
  const int k = indexOf(session_first);
  if (k < 0) throw std::invalid_argument(id("session_first", session_first) + " is unknown");
  if (decider_->closeJoining(k)) collectChanges();
}

void OnlineRrr::finish() {
  decider_->finish();
  decider_->endRun();  // what still waits (RRR: an unplaced session) stays unjoined
  collectChanges();
}

void OnlineRrr::decideClosedFromScratch() {
  decider_->decideClosedFromScratch();
  collectChanges();
}

void OnlineRrr::collectChanges() {
  for (int k = 0; k < numCandidates(); ++k) {
    const Verdict now = decider_->verdict(k);
    Verdict& before = reported_[static_cast<std::size_t>(k)];
    if (now == before) continue;
    const LoopCandidate& c = candidate(k);
    changes_.push_back({k, nodeIds()[static_cast<std::size_t>(c.from)],
                        nodeIds()[static_cast<std::size_t>(c.to)], decider_->clusterOf(k), now,
                        before, decider_->reason(k)});
    before = now;
  }
}

std::vector<DecisionChange> OnlineRrr::takeChanges() {
  std::vector<DecisionChange> out;
  out.swap(changes_);
  return out;
}

std::vector<std::string> OnlineRrr::takeDroppedCandidates() {
  std::vector<std::string> out;
  out.swap(dropped_);
  return out;
}

OnlineRrrStatus OnlineRrr::status() const {
  OnlineRrrStatus s;
  s.nodes = numNodes();
  s.sessions = graph_.chain().numSessions();
  s.candidates = numCandidates();
  s.marginal_edges = static_cast<int>(graph_.marginalLinks().size());
  s.dense_factors = numDenseFactors();
  s.waiting_candidates = static_cast<int>(waiting_.size());
  s.clusters = decider_->numClusters();
  s.open_clusters = decider_->numOpenClusters();
  for (Verdict v : reported_) {
    (v == Verdict::kAccepted ? s.accepted : v == Verdict::kRejected ? s.rejected : s.pending)++;
  }
  s.optimizations = decider_->optimizations();
  return s;
}

core::Pose2 OnlineRrr::mapToOdom() const {
  if (empty()) return core::Pose2::Zero();
  return core::compose(mapPoses().back(), core::inverse(odomPoses().back()));
}

core::PoseGraph OnlineRrr::poseGraph(const std::vector<core::Pose2>& poses,
                                     bool accepted_only) const {
  core::PoseGraph g;
  const auto& ids = nodeIds();
  for (int k = 0; k < numNodes(); ++k) {
    g.addNode(ids[static_cast<std::size_t>(k)], poses[static_cast<std::size_t>(k)]);
  }
  for (const Odometry& o : odometry_) {
    g.addEdge(ids[static_cast<std::size_t>(o.from)], ids[static_cast<std::size_t>(o.to)],
              o.measurement, o.information, core::EdgeKind::kOdometry);
  }
  const core::Optimizer& opt = graph_.optimizer();
  for (const MarginalLink& m : graph_.marginalLinks()) {
    g.addEdge(ids[static_cast<std::size_t>(m.from)], ids[static_cast<std::size_t>(m.to)],
              opt.measurement(m.constraint), opt.information(m.constraint),
              core::EdgeKind::kMarginal);
  }
  for (int f = 0; f < opt.numDenseFactors(); ++f) g.addDenseFactor(opt.denseFactor(f));
  for (int k = 0; k < numCandidates(); ++k) {
    if (accepted_only && verdict(k) != Verdict::kAccepted) continue;
    const LoopCandidate& c = candidate(k);
    g.addEdge(ids[static_cast<std::size_t>(c.from)], ids[static_cast<std::size_t>(c.to)],
              c.measurement, c.information, core::EdgeKind::kLoopCandidate);
  }
  return g;
}

core::PoseGraph OnlineRrr::toPoseGraph() const { return poseGraph(odomPoses(), false); }

core::PoseGraph OnlineRrr::optimizedPoseGraph() const { return poseGraph(mapPoses(), true); }

core::PoseGraph OnlineRrr::mapPoseGraph() const { return poseGraph(mapPoses(), false); }

std::vector<DecisionRow> OnlineRrr::decisionRows() const {
  std::vector<DecisionRow> rows;
  const auto& ids = nodeIds();
  for (int k = 0; k < numCandidates(); ++k) {
    const LoopCandidate& c = candidate(k);
    rows.push_back({ids[static_cast<std::size_t>(c.from)], ids[static_cast<std::size_t>(c.to)],
                    decider_->clusterOf(k), verdict(k), decider_->reason(k)});
  }
  return rows;
}

std::unique_ptr<OnlineRrr> OnlineRrr::fromPoseGraph(const core::PoseGraph& graph,
                                                    const OnlineRrrParams& params,
                                                    bool keep_open_clusters,
                                                    std::vector<core::Pose2> previous_map) {
  auto online = std::make_unique<OnlineRrr>(params);
  const std::vector<NodeId> ids = graph.nodeIds();
  const std::vector<ReplayEdge> edges = replayEdges(graph);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    if (edges[e].kind == core::EdgeKind::kOdometry && std::abs(edges[e].from - edges[e].to) != 1) {
      throw std::invalid_argument("odometry edge " + std::to_string(graph.edge(e).from) + " -> " +
                                  std::to_string(graph.edge(e).to) +
                                  " does not join consecutive nodes");
    }
  }
  const std::vector<NodeArrivals> arrivals =
      arrivalsByNode(static_cast<int>(ids.size()), edges, replayDenseFactors(graph));
  online->decider_->deferDecisions(true);  // finish() decides the whole graph once
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const int n = online->appendNode(ids[k], graph.pose(ids[k]));
    for (int i : arrivals[k].odometry) {
      const auto e = static_cast<std::size_t>(i);
      const ReplayEdge& edge = edges[e];
      online->graph_.addOdometry(edge.from, edge.to, graph.measurement(e), graph.information(e));
      online->odometry_.push_back({edge.from, edge.to, graph.measurement(e), graph.information(e)});
    }
    for (int i : arrivals[k].marginal) {
      const auto e = static_cast<std::size_t>(i);
      const ReplayEdge& edge = edges[e];
      online->graph_.addMarginal(edge.from, edge.to, graph.measurement(e), graph.information(e));
    }
    for (int f : arrivals[k].dense)
      online->addDenseFactor(graph.denseFactors()[static_cast<std::size_t>(f)]);
    online->decider_->advanceTo(n);
    for (int i : arrivals[k].candidates) {
      const auto e = static_cast<std::size_t>(i);
      online->insertCandidate(edges[e].from, edges[e].to, graph.measurement(e),
                              graph.information(e));
    }
  }
  online->decider_->deferDecisions(false);
  if (!previous_map.empty()) online->decider_->seedPreviousMap(std::move(previous_map));
  // Decided once, as a run's end would, but a loaded map goes on: clusters waiting for their
  // session to be placed keep waiting.
  if (keep_open_clusters) {
    online->decider_->finishReplayKeepingOpen();
  } else {
    online->decider_->finish();
  }
  online->collectChanges();
  return online;
}

}  // namespace rrr_graphslam::rrr
