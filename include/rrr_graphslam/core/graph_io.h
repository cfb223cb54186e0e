#pragma once
// Reading and writing SE(2) pose graphs in g2o (VERTEX_SE2 / EDGE_SE2) and TORO
// (VERTEX2 / EDGE2) text files, plain or gzip-compressed.
//
// The information matrix's upper triangle is stored in a different order by each format:
//   g2o : xx xy xt yy yt tt
//   TORO: xx xy yy tt xt yt
// MRPT's own loader (CNetworkOfPoses::loadFromTextFile, 2.5.8) reads EDGE2 in g2o order and
// silently skips self-loops, so this reader is strict and fills the MRPT network itself.
//
// Every bad input throws InputError naming the file and line: unknown tag, wrong field count,
// non-numeric field, NaN/inf, non-positive-definite information, edge to an unknown node,
// duplicate vertex id, self-loop; a disconnected graph is reported with its components.
// A file without VERTEX lines gets initial poses by chaining its odometry edges.

#include <ostream>
#include <string>

#include "rrr_graphslam/core/pose_graph.h"

namespace rrr_graphslam::core {

enum class GraphFormat { kG2o, kToro };

struct GraphReadOptions {
  /// Multi-session graphs are disconnected by nature; single-session tools reject them.
  bool allow_disconnected = false;  // default: false
};

/// Reads a g2o or TORO file (the tag of each line decides); ".gz" files are decompressed.
PoseGraph readPoseGraph(const std::string& path, const GraphReadOptions& options = {});

/// TORO for ".graph" and ".toro" (optionally followed by ".gz"), g2o otherwise.
GraphFormat formatFromPath(const std::string& path);

/// Writes nodes in id order and edges in insertion order, atomically. Numbers are written in
/// their shortest exact form, so reading the file back gives the same graph bit for bit. Dense
/// factors (dense_factor.h) follow the edges in g2o files as this product's own lines,
///   RRR_DENSE_SE2 n id_0 .. id_{n-1} y_1 .. y_{n-1} mean information offset
/// (each y three numbers, the mean 3(n-1), the information's upper triangle row by row), which
/// readPoseGraph reads back; g2o itself and other tools do not know them. TORO cannot hold them:
/// such a graph is refused (std::invalid_argument) rather than written without them.
void writePoseGraph(const PoseGraph& graph, const std::string& path, GraphFormat format);
/// The graph's text, for a file written with others (AtomicFileSet).
void writePoseGraph(const PoseGraph& graph, std::ostream& out, GraphFormat format);
void writePoseGraph(const PoseGraph& graph, const std::string& path);  ///< format from path

/// Human-readable list of components, e.g. "2 components: {0..99} (100 nodes), {100..149} ...".
std::string describeComponents(const PoseGraph& graph);

}  // namespace rrr_graphslam::core
