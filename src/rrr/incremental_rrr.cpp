#include "rrr_graphslam/rrr/incremental_rrr.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/rrr/clustering.h"

namespace rrr_graphslam::rrr {
namespace {

int newestEnd(const LoopCandidate& c) { return std::max(c.from, c.to); }

}  // namespace

IncrementalRrr::IncrementalRrr(VerificationGraph& graph, const RrrParams& params, int cluster_gap)
    : graph_(graph),
      rrr_(graph, params),
      open_(graph, cluster_gap),
      next_rebatch_(params.incremental_rebatch_every > 0 ? params.incremental_rebatch_every
                                                         : std::numeric_limits<int>::max()) {}

bool IncrementalRrr::addCandidate(int candidate) {
  bool closed = advanceTo(newestEnd(graph_.candidate(candidate)));
  if (open_.add(candidate)) closed = advanceTo(open_.currentNode()) || closed;
  return closed;
}

bool IncrementalRrr::advanceTo(int node) { return decideClosed(open_.advanceTo(node)); }

bool IncrementalRrr::closeJoining(int session_first) {
  return decideClosed(open_.closeJoining(session_first));
}

bool IncrementalRrr::decideClosed(const std::vector<std::vector<int>>& closed) {
  if (closed.empty()) return false;
  for (const std::vector<int>& members : closed) rrr_.addCluster(members);
  const bool rebatch = open_.currentNode() >= next_rebatch_;
  if (rebatch) scheduleNextRebatch();
  if (defer_) return true;
  // Sessions are placed again from scratch (with the previous map as a contender, see
  // Rrr::decideFromScratch); within one session a decision from scratch over part of the run
  // holds fewer loops against a false group than the online decisions (doc/rrr_extensions.md).
  if (rebatch && graph_.numTrustedComponents() > 1) {
    rrr_.decideFromScratch();
  } else {
    rrr_.decideIncrementally();
  }
  return true;
}

void IncrementalRrr::finish() {
  for (const std::vector<int>& members : open_.closeAll()) rrr_.addCluster(members);
  rrr_.decideFromScratch();
  // A loaded graph goes on from its own end, not from a schedule its replay left behind.
  scheduleNextRebatch();
}

void IncrementalRrr::finishReplayKeepingOpen() {
  rrr_.decideFromScratch();
  scheduleNextRebatch();
}

void IncrementalRrr::scheduleNextRebatch() {
  const int every = rrr_.params().incremental_rebatch_every;
  if (every > 0) next_rebatch_ = (open_.currentNode() / every + 1) * every;
}

RrrSummary runIncrementalRrr(VerificationGraph& graph, const RrrParams& params,
                             std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                             const ProgressFunction& progress, std::vector<double>* latencies_sec,
                             std::vector<std::string>* reasons, std::vector<ReplayEvent>* events) {
  const auto start = core::Clock::now();
  RrrSummary summary;
  summary.candidates = graph.numCandidates();
  const std::vector<CandidateEnds> ends = candidateEnds(graph);
  // Offline the gap can be derived from every candidate; a robot sets cluster_gap instead.
  summary.cluster_gap = clusterGapFor(params, ends);

  // What arrives with each node: its odometry, its marginal constraints and dense factors, then the
  // candidates whose newest end it is.
  const auto nodes = static_cast<std::size_t>(graph.numNodes());
  const core::Optimizer& full = graph.optimizer();
  std::vector<int> candidate_of(static_cast<std::size_t>(full.numConstraints()), -1);
  for (int k = 0; k < graph.numCandidates(); ++k)
    candidate_of[static_cast<std::size_t>(graph.candidate(k).constraint)] = k;
  std::vector<core::EdgeKind> kind(static_cast<std::size_t>(full.numConstraints()),
                                   core::EdgeKind::kOdometry);
  for (int k = 0; k < graph.numCandidates(); ++k)
    kind[static_cast<std::size_t>(graph.candidate(k).constraint)] = core::EdgeKind::kLoopCandidate;
  for (const MarginalLink& m : graph.marginalLinks())
    kind[static_cast<std::size_t>(m.constraint)] = core::EdgeKind::kMarginal;
  std::vector<ReplayEdge> edges;
  for (int c = 0; c < full.numConstraints(); ++c)
    edges.push_back({full.from(c), full.to(c), kind[static_cast<std::size_t>(c)]});
  std::vector<std::vector<int>> dense;
  for (int f = 0; f < full.numDenseFactors(); ++f) dense.push_back(full.denseFactorNodes(f));
  const std::vector<NodeArrivals> arrivals = arrivalsByNode(graph.numNodes(), edges, dense);

  // The robot's view: the graph holds the nodes that have arrived, not the whole run, so each
  // decision costs what it would cost on the robot at that point.
  VerificationGraph robot(full.params());
  IncrementalRrr incremental(robot, params, summary.cluster_gap);
  std::vector<int> arrival;  // robot's candidate index -> graph's
  arrival.reserve(static_cast<std::size_t>(graph.numCandidates()));
  if (latencies_sec) latencies_sec->clear();
  // The verdicts a robot was last told, by robot index; record() adds what changed since.
  std::vector<Verdict> told;
  if (events) events->clear();
  auto record = [&](int nodes_now, bool final) {
    if (!events) return;
    const Rrr& rrr = incremental.rrr();
    const double seconds = core::secondsSince(start);
    for (std::size_t i = 0; i < told.size(); ++i) {
      const int k = static_cast<int>(i);
      const Verdict now = rrr.verdict(k);
      if (now == told[i]) continue;
      events->push_back(
          {arrival[i], nodes_now, seconds, final, rrr.clusterOf(k), told[i], now, rrr.reason(k)});
      told[i] = now;
    }
  };
  for (std::size_t n = 0; n < nodes; ++n) {
    robot.addNode(graph.nodeIds()[n], graph.initialPoses()[n]);
    for (int c : arrivals[n].odometry) {
      robot.addOdometry(full.from(c), full.to(c), full.measurement(c), full.information(c));
    }
    for (int c : arrivals[n].marginal) {
      robot.addMarginal(full.from(c), full.to(c), full.measurement(c), full.information(c));
    }
    for (int f : arrivals[n].dense)
      robot.addDenseFactor(full.denseFactorNodes(f), full.denseFactor(f));
    // As on the robot (OnlineRrr): the node's arrival closes the clusters it has left behind and
    // decides them, whether or not a candidate comes with it.
    const auto node_start = core::Clock::now();
    if (incremental.advanceTo(static_cast<int>(n))) {
      if (latencies_sec) latencies_sec->push_back(core::secondsSince(node_start));
      record(static_cast<int>(n) + 1, false);
    }
    for (int constraint : arrivals[n].candidates) {
      const int k = candidate_of[static_cast<std::size_t>(constraint)];
      const LoopCandidate& c = graph.candidate(k);
      const auto t0 = core::Clock::now();
      incremental.addCandidate(
          robot.addCandidate(c.from, c.to, c.measurement, c.information, c.edge));
      if (latencies_sec) latencies_sec->push_back(core::secondsSince(t0));
      arrival.push_back(k);
      if (events) {
        events->push_back({k, static_cast<int>(n) + 1,
                           std::chrono::duration<double>(t0 - start).count(), false, -1,
                           Verdict::kPending, Verdict::kPending, std::string()});
        told.push_back(Verdict::kPending);
        record(static_cast<int>(n) + 1, false);
      }
      const auto done = static_cast<int>(arrival.size());
      if (progress && (done % 256 == 1 || done == graph.numCandidates())) {
        progress("incremental", done, graph.numCandidates());
      }
    }
  }
  incremental.finish();
  incremental.rrr().rejectUnplaced();
  record(static_cast<int>(nodes), true);

  std::vector<Verdict> robot_verdicts;
  std::vector<int> robot_clusters;
  std::vector<std::string> robot_reasons;
  collectVerdicts(incremental.rrr(), start, robot_verdicts, robot_clusters, summary,
                  &robot_reasons);
  verdicts.assign(arrival.size(), Verdict::kPending);
  cluster_of.assign(arrival.size(), -1);
  if (reasons != nullptr) reasons->assign(arrival.size(), std::string());
  std::vector<int> accepted;
  for (std::size_t i = 0; i < arrival.size(); ++i) {
    const auto k = static_cast<std::size_t>(arrival[i]);
    verdicts[k] = robot_verdicts[i];
    cluster_of[k] = robot_clusters[i];
    if (reasons != nullptr) (*reasons)[k] = robot_reasons[i];
    if (verdicts[k] == Verdict::kAccepted) accepted.push_back(arrival[i]);
  }
  // As after batch RRR: the graph's optimizer holds odometry + the accepted loops, optimized.
  graph.activateOnly(accepted);
  graph.optimizer().setPoses(robot.optimizer().poses());
  return summary;
}

}  // namespace rrr_graphslam::rrr
