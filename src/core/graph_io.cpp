#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/atomic_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <deque>
#include <map>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/core/line_parser.h"
#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::core {
namespace {

using NodeId = PoseGraph::NodeId;

constexpr const char* kDenseTag = "RRR_DENSE_SE2";

struct ParsedEdge {
  NodeId from;
  NodeId to;
  Pose2 measurement;
  Eigen::Matrix3d information;
  std::size_t line;
};

NodeId nodeId(const LineParser& parse, std::size_t k) {
  return static_cast<NodeId>(parse.unsignedInteger(k, "a node id (a non-negative integer)"));
}

// Reads the six upper-triangle values starting at `first`; `order` gives the (row, col) of each.
Eigen::Matrix3d information(const LineParser& parse, std::string_view tag, std::size_t first,
                            const int (&order)[6][2]) {
  Eigen::Matrix3d info;
  for (int k = 0; k < 6; ++k) {
    const double v = parse.number(first + static_cast<std::size_t>(k));
    info(order[k][0], order[k][1]) = v;
    info(order[k][1], order[k][0]) = v;
  }
  const std::string problem = informationProblem(info);
  if (!problem.empty()) parse.fail("information matrix of " + std::string(tag) + ": " + problem);
  return info;
}

constexpr int kG2oOrder[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
constexpr int kToroOrder[6][2] = {{0, 0}, {0, 1}, {1, 1}, {2, 2}, {0, 2}, {1, 2}};

// Initial poses for a file without vertices: a 0-1 breadth-first search from the smallest id in
// which odometry edges cost nothing and loop candidates cost one, so every node is placed along
// a path with as few loop candidates as possible (none when the odometry chain is connected).
// A node's pose is final when it leaves the queue; until then a cheaper path may replace it.
void chainInitialPoses(const std::string& path, const std::vector<ParsedEdge>& edges,
                       PoseGraph& graph) {
  std::map<NodeId, Pose2> poses;
  std::unordered_map<NodeId, std::vector<std::size_t>> incident;
  for (std::size_t k = 0; k < edges.size(); ++k) {
    incident[edges[k].from].push_back(k);
    incident[edges[k].to].push_back(k);
    poses.emplace(edges[k].from, Pose2::Zero());
    poses.emplace(edges[k].to, Pose2::Zero());
  }
  std::unordered_map<NodeId, std::size_t> cost;
  std::unordered_map<NodeId, bool> done;
  for (const auto& [root, unused] : poses) {
    if (cost.count(root)) continue;  // each disconnected part starts at its own smallest id
    cost[root] = 0;
    std::deque<NodeId> queue{root};
    while (!queue.empty()) {
      const NodeId n = queue.front();
      queue.pop_front();
      if (done[n]) continue;
      done[n] = true;
      for (std::size_t k : incident[n]) {
        const ParsedEdge& e = edges[k];
        const NodeId other = e.from == n ? e.to : e.from;
        if (done[other]) continue;
        const bool odometry = PoseGraph::defaultKind(e.from, e.to) == EdgeKind::kOdometry;
        const std::size_t through = cost[n] + (odometry ? 0 : 1);
        const auto known = cost.find(other);
        if (known != cost.end() && known->second <= through) continue;
        cost[other] = through;
        poses[other] = e.from == n ? compose(poses[n], e.measurement)
                                   : compose(poses[n], inverse(e.measurement));
        // Finite measurements can still chain beyond the doubles (1e308 + 1e308).
        if (!poses[other].allFinite()) {
          throw InputError(path, e.line,
                           "chaining the edges from node " + std::to_string(root) + " gives node " +
                               std::to_string(other) +
                               " a pose that is not finite (the file has no vertices)");
        }
        if (odometry) {
          queue.push_front(other);
        } else {
          queue.push_back(other);
        }
      }
    }
  }
  for (const auto& [id, pose] : poses) graph.addNode(id, pose);
}

std::string formatNumber(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, end);
}

std::string describeRange(const std::vector<NodeId>& ids) {
  const bool contiguous = ids.back() - ids.front() + 1 == ids.size();
  std::string text = "{" + std::to_string(ids.front());
  if (ids.size() > 1) text += (contiguous ? ".." : ",...,") + std::to_string(ids.back());
  return text + "} (" + std::to_string(ids.size()) + (ids.size() == 1 ? " node)" : " nodes)");
}

// One dense factor's line (graph_io.h): tag, node count, nodes, measurements, mean, the
// information's upper triangle row by row, the offset.
void writeDenseFactor(const DenseFactor& f, std::ostream& out) {
  out << kDenseTag << ' ' << f.nodes.size();
  for (NodeId id : f.nodes) out << ' ' << id;
  for (const Pose2& y : f.measurements) {
    out << ' ' << formatNumber(y.x()) << ' ' << formatNumber(y.y()) << ' ' << formatNumber(y.z());
  }
  for (Eigen::Index r = 0; r < f.mean.size(); ++r) out << ' ' << formatNumber(f.mean(r));
  for (Eigen::Index r = 0; r < f.information.rows(); ++r) {
    for (Eigen::Index c = r; c < f.information.cols(); ++c) {
      out << ' ' << formatNumber(f.information(r, c));
    }
  }
  out << ' ' << formatNumber(f.chi2_offset) << '\n';
}

DenseFactor readDenseFactor(const LineParser& parse) {
  parse.expectAtLeast(1, "a node count");
  const std::uint64_t n = parse.unsignedInteger(1, "the node count (an integer of at least 2)");
  if (n < 2) parse.fail("node count " + std::to_string(n) + ": a dense factor has 2 or more");
  if (n > parse.size()) {
    parse.fail("node count " + std::to_string(n) + " exceeds the line's " +
               std::to_string(parse.size() - 1) + " fields");
  }
  const std::size_t k = static_cast<std::size_t>(n) - 1, rows = 3 * k;
  parse.expectCount(1 + n + 3 * k + rows + rows * (rows + 1) / 2 + 1);
  DenseFactor f;
  std::size_t at = 2;
  for (std::size_t i = 0; i < n; ++i) f.nodes.push_back(nodeId(parse, at++));
  for (std::size_t a = 0; a < k; ++a, at += 3) f.measurements.push_back(parse.pose(at));
  f.mean.resize(static_cast<Eigen::Index>(rows));
  for (std::size_t r = 0; r < rows; ++r) f.mean(static_cast<Eigen::Index>(r)) = parse.number(at++);
  f.information.resize(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(rows));
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = r; c < rows; ++c) {
      const auto i = static_cast<Eigen::Index>(r), j = static_cast<Eigen::Index>(c);
      f.information(i, j) = f.information(j, i) = parse.number(at++);
    }
  }
  f.chi2_offset = parse.number(at);
  const std::string problem = denseFactorProblem(f);
  if (!problem.empty()) parse.fail("dense factor: " + problem);
  return f;
}

}  // namespace

GraphFormat formatFromPath(const std::string& path) {
  std::string p = path;
  if (p.size() > 3 && p.compare(p.size() - 3, 3, ".gz") == 0) p.resize(p.size() - 3);
  for (const std::string ext : {".graph", ".toro"}) {
    if (p.size() > ext.size() && p.compare(p.size() - ext.size(), ext.size(), ext) == 0) {
      return GraphFormat::kToro;
    }
  }
  return GraphFormat::kG2o;
}

std::string describeComponents(const PoseGraph& graph) {
  const auto components = graph.connectedComponents();
  std::string text = std::to_string(components.size()) + " components: ";
  const std::size_t shown = std::min<std::size_t>(components.size(), 8);
  for (std::size_t c = 0; c < shown; ++c) text += (c ? ", " : "") + describeRange(components[c]);
  if (shown < components.size()) text += ", ...";
  return text;
}

PoseGraph readPoseGraph(const std::string& path, const GraphReadOptions& options) {
  LineReader reader(path);
  PoseGraph graph;
  std::unordered_map<NodeId, std::size_t> vertex_line;
  std::vector<ParsedEdge> edges;
  std::vector<std::pair<DenseFactor, std::size_t>> dense;  // with its line
  std::string line;
  while (reader.next(line)) {
    const auto fields = splitFields(line);
    if (fields.empty() || fields[0].front() == '#') continue;
    const std::string_view tag = fields[0];
    const LineParser parse(reader, tag, fields);
    if (tag == "VERTEX_SE2" || tag == "VERTEX2") {
      parse.expectCount(4);
      const NodeId id = nodeId(parse, 1);
      const Pose2 pose = parse.pose(2);
      const auto [it, inserted] = vertex_line.emplace(id, reader.lineNumber());
      if (!inserted) {
        parse.fail("duplicate vertex id " + std::to_string(id) + " (first defined on line " +
                   std::to_string(it->second) + ")");
      }
      graph.addNode(id, pose);
    } else if (tag == "EDGE_SE2" || tag == "EDGE2") {
      parse.expectCount(11);
      ParsedEdge e;
      e.from = nodeId(parse, 1);
      e.to = nodeId(parse, 2);
      if (e.from == e.to)
        parse.fail("self-loop: edge from node " + std::to_string(e.from) + " to itself");
      e.measurement = parse.pose(3);
      e.measurement.z() = normalizeAngle(e.measurement.z());
      e.information = information(parse, tag, 6, tag == "EDGE_SE2" ? kG2oOrder : kToroOrder);
      e.line = reader.lineNumber();
      edges.push_back(e);
    } else if (tag == kDenseTag) {
      dense.emplace_back(readDenseFactor(parse), reader.lineNumber());
    } else {
      parse.fail("unknown tag '" + std::string(tag) +
                 "' (expected VERTEX_SE2, EDGE_SE2, VERTEX2, EDGE2 or " + kDenseTag + ")");
    }
  }

  if (vertex_line.empty()) {
    chainInitialPoses(path, edges, graph);
  }
  for (const ParsedEdge& e : edges) {
    for (NodeId end : {e.from, e.to}) {
      if (!graph.hasNode(end)) {
        throw InputError(path, e.line, "edge refers to unknown node " + std::to_string(end));
      }
    }
    graph.addEdge(e.from, e.to, e.measurement, e.information, PoseGraph::defaultKind(e.from, e.to));
  }
  for (auto& [factor, at] : dense) {
    for (NodeId id : factor.nodes) {
      if (!graph.hasNode(id)) {
        throw InputError(path, at, "dense factor refers to unknown node " + std::to_string(id));
      }
    }
    graph.addDenseFactor(std::move(factor));
  }
  if (graph.numNodes() == 0) throw InputError(path, 0, "no vertices or edges in the file");
  if (!options.allow_disconnected && graph.connectedComponents().size() > 1) {
    throw InputError(path, 0, "graph is disconnected: " + describeComponents(graph));
  }
  return graph;
}

void writePoseGraph(const PoseGraph& graph, std::ostream& out, GraphFormat format) {
  const bool g2o = format == GraphFormat::kG2o;
  if (!g2o && !graph.denseFactors().empty()) {
    throw std::invalid_argument(
        "the graph holds " + std::to_string(graph.denseFactors().size()) +
        " dense factors (lifelong trimming with sparsification dense), which TORO files cannot "
        "hold (g2o files can, as " +
        std::string(kDenseTag) + " lines): nothing was written");
  }
  for (NodeId id : graph.nodeIds()) {
    const Pose2 p = graph.pose(id);
    out << (g2o ? "VERTEX_SE2 " : "VERTEX2 ") << id << ' ' << formatNumber(p.x()) << ' '
        << formatNumber(p.y()) << ' ' << formatNumber(p.z()) << '\n';
  }
  const auto& order = g2o ? kG2oOrder : kToroOrder;
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const auto& e = graph.edge(k);
    const Pose2 z = graph.measurement(k);
    const Eigen::Matrix3d info = graph.information(k);
    out << (g2o ? "EDGE_SE2 " : "EDGE2 ") << e.from << ' ' << e.to << ' ' << formatNumber(z.x())
        << ' ' << formatNumber(z.y()) << ' ' << formatNumber(z.z());
    for (const auto& rc : order) out << ' ' << formatNumber(info(rc[0], rc[1]));
    out << '\n';
  }
  for (const DenseFactor& f : graph.denseFactors()) writeDenseFactor(f, out);
}

void writePoseGraph(const PoseGraph& graph, const std::string& path, GraphFormat format) {
  writeFileAtomically(path, [&](std::ostream& out) { writePoseGraph(graph, out, format); });
}

void writePoseGraph(const PoseGraph& graph, const std::string& path) {
  writePoseGraph(graph, path, formatFromPath(path));
}

}  // namespace rrr_graphslam::core
