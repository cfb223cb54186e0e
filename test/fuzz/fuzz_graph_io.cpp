// libFuzzer target of core::readPoseGraph: g2o and TORO (the tag of each line decides), plain or
// gzip. Disconnected graphs are allowed, so an accepted input is read to the end.
//
// A bad input must throw InputError (std::invalid_argument from PoseGraph is let pass too).
// Besides crashes and sanitizer errors it checks what graph_io.h and pose_graph.h promise for
// an accepted file: every pose, measurement and information entry finite (NaN/inf are rejected,
// and chained initial poses must not overflow into them); a copy equal to the original; and the
// graph written in either format and read back identical bit for bit.

#include <stdlib.h>
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

#include "fuzz_input.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::fuzz {
namespace {

using core::PoseGraph;

bool finite(const Eigen::Matrix3d& m) { return m.allFinite(); }
bool finite(const core::Pose2& p) { return p.allFinite(); }

bool sameGraph(const PoseGraph& a, const PoseGraph& b) {
  if (a.nodeIds() != b.nodeIds() || a.numEdges() != b.numEdges()) return false;
  for (PoseGraph::NodeId id : a.nodeIds()) {
    if (a.pose(id) != b.pose(id)) return false;
  }
  for (std::size_t k = 0; k < a.numEdges(); ++k) {
    const PoseGraph::Edge& ea = a.edge(k);
    const PoseGraph::Edge& eb = b.edge(k);
    if (ea.from != eb.from || ea.to != eb.to || ea.kind != eb.kind) return false;
    if (a.measurement(k) != b.measurement(k) || a.information(k) != b.information(k)) return false;
  }
  if (a.denseFactors().size() != b.denseFactors().size()) return false;
  for (std::size_t k = 0; k < a.denseFactors().size(); ++k) {
    const core::DenseFactor& fa = a.denseFactors()[k];
    const core::DenseFactor& fb = b.denseFactors()[k];
    if (fa.nodes != fb.nodes || fa.measurements != fb.measurements || fa.mean != fb.mean ||
        fa.information != fb.information || fa.chi2_offset != fb.chi2_offset) {
      return false;
    }
  }
  return true;
}

// writePoseGraph writes a temporary file beside the target and renames it, so it needs a real
// folder: one per process, under TMPDIR (scripts/fuzz points it to a folder in /dev/shm that it
// removes at exit, so a crash leaves nothing behind), else in /dev/shm (no disk writes).
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmpdir = std::getenv("TMPDIR");
    const char* base = tmpdir != nullptr && *tmpdir != '\0' ? tmpdir
                       : access("/dev/shm", W_OK) == 0      ? "/dev/shm"
                                                            : "/tmp";
    std::string name = std::string(base) + "/rrr_fuzz_graph_io.XXXXXX";
    if (mkdtemp(name.data()) == nullptr) {
      std::perror("[fuzz] mkdtemp");
      std::abort();
    }
    dir_ = name;
  }
  ~ScratchDir() {
    for (const char* file : {"/roundtrip.g2o", "/roundtrip.graph"}) {
      std::remove((dir_ + file).c_str());
    }
    rmdir(dir_.c_str());
  }
  std::string file(const char* name) const { return dir_ + "/" + name; }

 private:
  std::string dir_;
};

void checkRoundTrip(const PoseGraph& graph, const std::string& path) {
  if (core::formatFromPath(path) == core::GraphFormat::kToro && !graph.denseFactors().empty()) {
    bool refused = false;  // TORO cannot hold dense factors: refused, never written without them
    try {
      core::writePoseGraph(graph, path);
    } catch (const std::invalid_argument&) {
      refused = true;
    }
    RRR_FUZZ_CHECK(refused, "a graph with dense factors is not written as TORO");
    return;
  }
  core::writePoseGraph(graph, path);
  PoseGraph again;
  try {
    again = core::readPoseGraph(path, {true});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[fuzz] reading the written graph back failed: %s\n", e.what());
    RRR_FUZZ_CHECK(false, "a graph the reader accepted is written in a form it accepts");
  }
  RRR_FUZZ_CHECK(sameGraph(graph, again), "write then read gives the same graph bit for bit");
}

}  // namespace
}  // namespace rrr_graphslam::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace core = rrr_graphslam::core;
  namespace fuzz = rrr_graphslam::fuzz;
  static const fuzz::ScratchDir scratch;
  const std::string& path = fuzz::writeInput(data, size);
  core::PoseGraph graph;
  try {
    graph = core::readPoseGraph(path, {true});
  } catch (const core::InputError&) {
    return 0;  // a bad input, reported as the reader promises
  } catch (const std::invalid_argument&) {
    return 0;  // PoseGraph's own checks, should the reader's ever miss one
  } catch (const std::exception& e) {
    fuzz::unexpectedException(e);
  }

  RRR_FUZZ_CHECK(graph.numNodes() > 0, "an accepted graph has nodes");
  for (core::PoseGraph::NodeId id : graph.nodeIds()) {
    RRR_FUZZ_CHECK(fuzz::finite(graph.pose(id)), "every node pose is finite");
  }
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const auto& e = graph.edge(k);
    RRR_FUZZ_CHECK(graph.hasNode(e.from) && graph.hasNode(e.to) && e.from != e.to,
                   "every edge joins two different known nodes");
    RRR_FUZZ_CHECK(e.kind == core::PoseGraph::defaultKind(e.from, e.to), "edge kind by id gap");
    RRR_FUZZ_CHECK(fuzz::finite(graph.measurement(k)), "every measurement is finite");
    RRR_FUZZ_CHECK(fuzz::finite(graph.information(k)), "every information matrix is finite");
  }
  std::size_t in_components = 0;
  for (const auto& component : graph.connectedComponents()) in_components += component.size();
  RRR_FUZZ_CHECK(in_components == graph.numNodes(), "components partition the nodes");
  RRR_FUZZ_CHECK(!core::describeComponents(graph).empty(), "components can be described");

  const core::PoseGraph copy = graph;
  RRR_FUZZ_CHECK(fuzz::sameGraph(graph, copy), "a copy equals its original");

  fuzz::checkRoundTrip(graph, scratch.file("roundtrip.g2o"));
  fuzz::checkRoundTrip(graph, scratch.file("roundtrip.graph"));
  return 0;
}
