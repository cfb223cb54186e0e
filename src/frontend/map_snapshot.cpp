#include "rrr_graphslam/frontend/map_snapshot.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "rrr_graphslam/frontend/plausible_pose.h"

namespace rrr_graphslam::frontend {
namespace {

// A remembered patch is a tile of a session's view: 10 m and its margins.
constexpr double kMaxPatchExtent = 1e3;

}  // namespace

void MapSnapshot::check() const {
  const int n = static_cast<int>(nodes.size());
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (format_version == 0 || format_version > kMapFormatVersion) {
    fail("format version " + std::to_string(format_version) +
         " is not one this build writes (1 to " + std::to_string(kMapFormatVersion) + ")");
  }
  if (lifelong.trimmed_submaps < 0 || lifelong.marginalized_nodes < 0) {
    fail("the lifelong counts are negative");
  }
  if (format_version < 2 && (lifelong.trimmed_submaps > 0 || lifelong.marginalized_nodes > 0)) {
    fail("format version 1 cannot hold the lifelong counts");
  }
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    const int first = sessions[k].first_node;
    const int next = k + 1 < sessions.size() ? sessions[k + 1].first_node : n;
    if (!std::isfinite(sessions[k].start_time)) {
      fail("session " + std::to_string(k) + "'s start time is not finite");
    }
    if (first < 0 || first >= next || next > n) {
      fail("session " + std::to_string(k) + " starts at node " + std::to_string(first) +
           ", not before the next session or the end");
    }
    const int number = sessions[k].number;
    if (number < 0 || number > 1'000'000'000 || (k > 0 && number <= sessions[k - 1].number)) {
      fail("session " + std::to_string(k) + " has number " + std::to_string(number) +
           ", not above the session before's (numbers grow over the map's life)");
    }
    if (format_version < 3 && number != static_cast<int>(k)) {
      fail("session " + std::to_string(k) + " has number " + std::to_string(number) +
           ", which format version " + std::to_string(format_version) +
           " cannot hold (it numbers sessions in order)");
    }
  }
  if (format_version < 3 && !memory.empty()) {
    fail("format version " + std::to_string(format_version) +
         " cannot hold the memory of trimmed submaps");
  }
  for (std::size_t k = 0; k < memory.size(); ++k) {
    const RememberedCells& patch = memory[k];
    try {
      patch.check(n);
      if (patch.origin.head<2>().cwiseAbs().maxCoeff() > kMaxCoordinate ||
          std::max(patch.width, patch.height) * patch.resolution_m > kMaxPatchExtent) {
        fail("it lies beyond 1e6 m of its anchor or spans more than 1 km");
      }
      if (!sessions.empty() && patch.session > sessions.back().number) {
        fail("its session " + std::to_string(patch.session) + " is newer than the map's newest");
      }
    } catch (const std::invalid_argument& e) {
      fail("remembered patch " + std::to_string(k) + ": " + e.what());
    }
  }
  if (n > 0 && (sessions.empty() || sessions.front().first_node != 0)) {
    fail("the first session does not start at node 0");
  }
  for (int k = 0; k < n; ++k) {
    const Node& node = nodes[static_cast<std::size_t>(k)];
    if (node.session < 0 || node.session >= static_cast<int>(sessions.size()) ||
        sessions[static_cast<std::size_t>(node.session)].first_node > k ||
        (node.session + 1 < static_cast<int>(sessions.size()) &&
         sessions[static_cast<std::size_t>(node.session) + 1].first_node <= k)) {
      fail("node " + std::to_string(k) + " names session " + std::to_string(node.session) +
           ", which does not hold it");
    }
    // The limits local SLAM holds live scans to: the grids rebuilt from these must stay sane.
    auto plausible = [](const core::Pose2& p) {
      return p.allFinite() && p.head<2>().cwiseAbs().maxCoeff() <= kMaxCoordinate;
    };
    if (!plausible(node.local_pose) || !plausible(node.map_pose) ||
        !std::isfinite(node.timestamp)) {
      fail("node " + std::to_string(k) + " has a pose beyond 1e6 m or a value that is not finite");
    }
    if (node.scan == nullptr) fail("node " + std::to_string(k) + " has no scan");
    const auto& scan = *node.scan;
    const auto& laser = scan.sensorPose;
    if (std::hypot(laser.x(), laser.y()) > kMaxLaserOffset ||
        std::abs(laser.z()) > kMaxLaserOffset || !(scan.maxRange > 0.0F) ||
        !std::isfinite(scan.maxRange) || !std::isfinite(scan.aperture)) {
      fail("node " + std::to_string(k) +
           "'s scan has its laser more than 100 m from the robot, or a maximum range or aperture "
           "that is not finite and positive");
    }
    for (std::size_t i = 0; i < scan.getScanSize(); ++i) {
      const float r = scan.getScanRange(i);
      if (scan.getScanRangeValidity(i) && !(r >= 0.0F && r <= scan.maxRange)) {
        fail("node " + std::to_string(k) + "'s scan has a valid reading outside [0, maxRange]");
      }
    }
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = edges[k];
    if (e.from < 0 || e.to < 0 || e.from >= n || e.to >= n || e.from == e.to) {
      fail("edge " + std::to_string(k) + " joins " + std::to_string(e.from) + " and " +
           std::to_string(e.to) + ", not two of the " + std::to_string(n) + " nodes");
    }
    if (e.kind == EdgeKind::kOdometry &&
        (std::abs(e.from - e.to) != 1 || nodes[static_cast<std::size_t>(e.from)].session !=
                                             nodes[static_cast<std::size_t>(e.to)].session)) {
      fail("odometry edge " + std::to_string(k) + " does not join consecutive nodes of a session");
    }
    if (e.kind == EdgeKind::kMarginal && format_version < 2) {
      fail("edge " + std::to_string(k) + " is marginal, which format version 1 cannot hold");
    }
    if (e.source != LoopSource::kUnknown && e.kind != EdgeKind::kLoopCandidate) {
      fail("edge " + std::to_string(k) + " has a loop source but is no loop candidate");
    }
    if (e.source != LoopSource::kUnknown && format_version < 4) {
      fail("edge " + std::to_string(k) + " has a loop source, which format version " +
           std::to_string(format_version) + " cannot hold");
    }
    if (e.source == LoopSource::kRivalSearch && format_version < 6) {
      fail("edge " + std::to_string(k) + " comes from the rival search, which format version " +
           std::to_string(format_version) + " cannot name");
    }
    if (!e.measurement.allFinite() || !e.information.allFinite()) {
      fail("edge " + std::to_string(k) + " has a measurement or information that is not finite");
    }
  }
  if (format_version < 5 && !dense_factors.empty()) {
    fail("format version " + std::to_string(format_version) + " cannot hold dense factors");
  }
  for (std::size_t k = 0; k < dense_factors.size(); ++k) {
    const core::DenseFactor& f = dense_factors[k];
    if (f.nodes.size() > kMaxDenseFactorNodes) {  // before the factorization below
      fail("dense factor " + std::to_string(k) + " holds " + std::to_string(f.nodes.size()) +
           " nodes, more than the " + std::to_string(kMaxDenseFactorNodes) + " a map file holds");
    }
    for (auto id : f.nodes) {
      if (id >= static_cast<std::size_t>(n)) {
        fail("dense factor " + std::to_string(k) + " holds node " + std::to_string(id) +
             ", not one of the " + std::to_string(n) + " nodes");
      }
    }
    const std::string problem = core::denseFactorProblem(f);
    if (!problem.empty()) fail("dense factor " + std::to_string(k) + ": " + problem);
  }
  for (std::size_t k = 0; k < submaps.size(); ++k) {
    const Submap& s = submaps[k];
    if (s.first_node < 0 || s.first_node > s.last_node || s.last_node >= n ||
        nodes[static_cast<std::size_t>(s.first_node)].session !=
            nodes[static_cast<std::size_t>(s.last_node)].session) {
      fail("submap " + std::to_string(k) + " spans nodes " + std::to_string(s.first_node) + " to " +
           std::to_string(s.last_node) + ", not nodes of one session");
    }
  }
}

std::string toString(LoopSource source) { return core::choiceName(source); }

core::EdgeKind toCoreKind(MapSnapshot::EdgeKind kind) {
  switch (kind) {
    case MapSnapshot::EdgeKind::kOdometry:
      return core::EdgeKind::kOdometry;
    case MapSnapshot::EdgeKind::kMarginal:
      return core::EdgeKind::kMarginal;
    case MapSnapshot::EdgeKind::kLoopCandidate:
      break;
  }
  return core::EdgeKind::kLoopCandidate;
}

namespace {

core::PoseGraph poseGraphOf(const MapSnapshot& map, bool trusted_only) {
  core::PoseGraph graph;
  for (std::size_t k = 0; k < map.nodes.size(); ++k) {
    graph.addNode(static_cast<core::PoseGraph::NodeId>(k), map.nodes[k].map_pose);
  }
  for (const auto& e : map.edges) {
    if (trusted_only && e.kind == MapSnapshot::EdgeKind::kLoopCandidate &&
        e.verdict != rrr::Verdict::kAccepted) {
      continue;
    }
    graph.addEdge(static_cast<core::PoseGraph::NodeId>(e.from),
                  static_cast<core::PoseGraph::NodeId>(e.to), e.measurement, e.information,
                  toCoreKind(e.kind));
  }
  for (const core::DenseFactor& f : map.dense_factors) graph.addDenseFactor(f);
  return graph;
}

}  // namespace

core::PoseGraph mapPoseGraph(const MapSnapshot& map) { return poseGraphOf(map, false); }

core::PoseGraph trustedPoseGraph(const MapSnapshot& map) { return poseGraphOf(map, true); }

}  // namespace rrr_graphslam::frontend
