// g2o / TORO reading and writing: format cross-check, round trips, and every bad input.

#include <gtest/gtest.h>

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::core {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/rrr_graph_io_XXXXXX";
    path_ = mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string file(const std::string& name, const std::string& content = "") const {
    const std::string p = path_ + "/" + name;
    if (!content.empty()) std::ofstream(p) << content;
    return p;
  }

 private:
  std::string path_;
};

void expectSameGraph(const PoseGraph& a, const PoseGraph& b, double tolerance) {
  ASSERT_EQ(a.nodeIds(), b.nodeIds());
  for (auto id : a.nodeIds()) EXPECT_LE((a.pose(id) - b.pose(id)).norm(), tolerance) << id;
  ASSERT_EQ(a.numEdges(), b.numEdges());
  for (std::size_t k = 0; k < a.numEdges(); ++k) {
    EXPECT_EQ(a.edge(k).from, b.edge(k).from);
    EXPECT_EQ(a.edge(k).to, b.edge(k).to);
    EXPECT_EQ(a.edge(k).kind, b.edge(k).kind);
    EXPECT_LE((a.measurement(k) - b.measurement(k)).norm(), tolerance) << "edge " << k;
    EXPECT_LE((a.information(k) - b.information(k)).norm(),
              tolerance * (1.0 + a.information(k).norm()))
        << "edge " << k;
  }
}

TEST(GraphIo, CsailG2oAndToroAreTheSameGraph) {
  const PoseGraph g2o = readPoseGraph(kData + "/csail.g2o.gz");
  const PoseGraph toro = readPoseGraph(kData + "/csail.toro.gz");
  EXPECT_EQ(g2o.numNodes(), 1045u);
  EXPECT_EQ(g2o.numEdges(), 1172u);
  expectSameGraph(g2o, toro, 1e-9);
  // An information matrix with distinct off-diagonal terms, so a mixed-up order would show.
  EXPECT_NE(g2o.information(0)(0, 1), 0.0);
}

// MRPT's loader is the reference for g2o files without duplicate edges (it keeps one edge per
// pair: it loads 1835 of Intel's 1837 edges and 1171 of CSAIL's 1172, one reason PoseGraph has
// its own reader).
TEST(GraphIo, AgreesWithMrptLoaderOnG2o) {
  TempDir dir;
  const std::string plain = dir.file("ring.g2o");
  writePoseGraph(readPoseGraph(kData + "/ring.g2o.gz"), plain);
  const PoseGraph ours = readPoseGraph(plain);
  mrpt::graphs::CNetworkOfPoses2DInf mrpt_graph;
  mrpt_graph.loadFromTextFile(plain);
  ASSERT_EQ(mrpt_graph.nodes.size(), ours.numNodes());
  ASSERT_EQ(mrpt_graph.edges.size(), ours.numEdges());
  for (const auto& [id, pose] : mrpt_graph.nodes) {
    EXPECT_NEAR((ours.pose(id) - Pose2(pose.x(), pose.y(), pose.phi())).norm(), 0.0, 1e-12);
  }
  // The MRPT network inside PoseGraph holds the same edges as MRPT's own loader.
  auto it = mrpt_graph.edges.begin();
  for (auto mine = ours.network().edges.begin(); mine != ours.network().edges.end(); ++mine, ++it) {
    EXPECT_EQ(mine->first, it->first);
    EXPECT_NEAR((mine->second.cov_inv - it->second.cov_inv).norm(), 0.0, 1e-9);
  }
}

TEST(GraphIo, RoundTripInBothFormatsIsExact) {
  TempDir dir;
  const PoseGraph original = readPoseGraph(kData + "/csail.g2o.gz");
  for (const char* name : {"out.g2o", "out.toro", "out.graph"}) {
    const std::string path = dir.file(name);
    writePoseGraph(original, path);
    expectSameGraph(original, readPoseGraph(path), 0.0);
  }
  EXPECT_EQ(formatFromPath("a.graph.gz"), GraphFormat::kToro);
  EXPECT_EQ(formatFromPath("a.g2o"), GraphFormat::kG2o);
}

// A graph keeps every angle as given (wrapped exactly into (-pi, pi]), so angles at the wrap
// point read back bit for bit: MRPT's CPose2D(x, y, phi) kept 0.1 as 0.10000000000000009 and sent
// the double just below -pi to +pi, which a written file then read back as -pi (a fuzz finding,
// test/fuzz/regressions/graph_io/vertex_angle_just_below_minus_pi.g2o).
TEST(GraphIo, AnglesAtTheWrapPointRoundTripBitForBit) {
  const double below_minus_pi = std::nextafter(-M_PI, -4.0);
  const double angles[] = {0.1, M_PI, -M_PI, below_minus_pi, std::nextafter(M_PI, 4.0), 7.0};
  PoseGraph graph;
  PoseGraph::NodeId id = 0;
  for (double angle : angles) graph.addNode(id++, Pose2(0.5, -0.25, angle));
  for (PoseGraph::NodeId k = 1; k < id; ++k) {
    graph.addEdge(k - 1, k, Pose2(1.0, 0.0, angles[k - 1]), Eigen::Matrix3d::Identity(),
                  EdgeKind::kOdometry);
  }
  EXPECT_EQ(graph.measurement(0).z(), 0.1);
  EXPECT_EQ(graph.measurement(2).z(), M_PI);
  EXPECT_EQ(graph.pose(0).z(), 0.1);
  EXPECT_EQ(graph.pose(1).z(), M_PI);
  EXPECT_EQ(graph.pose(2).z(), M_PI);                       // -pi is pi in (-pi, pi]
  EXPECT_EQ(graph.pose(3).z(), std::nextafter(M_PI, 0.0));  // -pi - ulp + 2 pi, exactly
  for (PoseGraph::NodeId k = 0; k < id; ++k) {
    EXPECT_GT(graph.pose(k).z(), -M_PI);
    EXPECT_LE(graph.pose(k).z(), M_PI);
  }
  TempDir dir;
  for (const char* name : {"out.g2o", "out.graph"}) {
    const std::string path = dir.file(name);
    writePoseGraph(graph, path);
    expectSameGraph(graph, readPoseGraph(path), 0.0);
  }
}

// Dense factors travel in g2o files as RRR_DENSE_SE2 lines, exactly; TORO refuses them.
TEST(GraphIo, DenseFactorsRoundTripInG2o) {
  TempDir dir;
  PoseGraph graph;
  for (PoseGraph::NodeId id = 0; id < 4; ++id)
    graph.addNode(id, Pose2(0.5 * id, 0.1 * id, 0.2 * id));
  graph.addEdge(0, 1, Pose2(0.5, 0.1, 0.2), Eigen::Matrix3d::Identity(), EdgeKind::kOdometry);
  graph.addEdge(2, 3, Pose2(0.5, 0.1, 0.2), Eigen::Matrix3d::Identity(), EdgeKind::kOdometry);
  DenseFactor f;
  f.nodes = {1, 2, 3};
  f.measurements = {Pose2(0.5, 0.1, 0.2), Pose2(1.0 / 3.0, 0.2, -0.1)};
  f.mean = Eigen::VectorXd::LinSpaced(6, -0.01, 0.02);
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(6, 6);
  f.information = a * a.transpose() + 6.0 * Eigen::MatrixXd::Identity(6, 6);
  f.chi2_offset = 0.125;
  graph.addDenseFactor(f);
  const std::string path = dir.file("dense.g2o");
  writePoseGraph(graph, path);
  const PoseGraph read = readPoseGraph(path);  // connected only through the factor
  expectSameGraph(graph, read, 0.0);
  ASSERT_EQ(read.denseFactors().size(), 1u);
  const DenseFactor& g = read.denseFactors()[0];
  EXPECT_EQ(g.nodes, f.nodes);
  EXPECT_EQ(g.measurements, f.measurements);
  EXPECT_EQ(g.mean, f.mean);
  EXPECT_EQ(g.information, f.information);
  EXPECT_EQ(g.chi2_offset, f.chi2_offset);
  EXPECT_THROW(writePoseGraph(graph, dir.file("dense.toro")), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.file("dense.toro")));
}

TEST(GraphIo, DuplicateEdgesStaySeparateAndInOrder) {
  TempDir dir;
  const std::string path = dir.file("dup.g2o",
                                    "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
                                    "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 0 2 2 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 0 2 2.5 0 0 2 0 0 2 0 2\n");
  const PoseGraph g = readPoseGraph(path);
  ASSERT_EQ(g.numEdges(), 4u);
  EXPECT_EQ(g.edge(2).kind, EdgeKind::kLoopCandidate);
  EXPECT_EQ(g.edge(1).kind, EdgeKind::kOdometry);
  EXPECT_DOUBLE_EQ(g.measurement(2).x(), 2.0);
  EXPECT_DOUBLE_EQ(g.measurement(3).x(), 2.5);
  const PoseGraph copy = g;  // copies re-point their edge storage
  EXPECT_DOUBLE_EQ(copy.measurement(3).x(), 2.5);
  EXPECT_EQ(copy.edge(3).storage, std::next(copy.edge(2).storage));
  EXPECT_NE(&*copy.edge(3).storage, &*g.edge(3).storage);
}

TEST(GraphIo, EdgeOnlyFileChainsOdometry) {
  const PoseGraph g = readPoseGraph(kData + "/kitti_07_odom.g2o.gz");
  EXPECT_EQ(g.numNodes(), 1101u);
  EXPECT_EQ(g.numEdges(), 1100u);
  // Node k+1 = node k composed with the odometry edge between them.
  for (std::size_t k = 0; k < g.numEdges(); ++k) {
    const auto& e = g.edge(k);
    const Pose2 predicted = compose(g.pose(e.from), g.measurement(k));
    Pose2 d = predicted - g.pose(e.to);
    d.z() = normalizeAngle(d.z());
    EXPECT_LT(d.norm(), 1e-9) << "edge " << k;
  }
}

TEST(GraphIo, EdgeOnlyFilePlacesNodesByOdometryEvenWhenALoopReachesThemFirst) {
  // Node 3 is adjacent to node 0 through a (wrong) loop before odometry reaches it.
  TempDir dir;
  const std::string path = dir.file("loops_first.g2o",
                                    "EDGE_SE2 0 3 9 9 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 2 3 1 0 0 1 0 0 1 0 1\n"
                                    "EDGE_SE2 3 4 1 0 0 1 0 0 1 0 1\n");
  const PoseGraph g = readPoseGraph(path);
  for (PoseGraph::NodeId id = 0; id <= 4; ++id) {
    EXPECT_NEAR((g.pose(id) - Pose2(static_cast<double>(id), 0, 0)).norm(), 0.0, 1e-12) << id;
  }
}

struct BadInput {
  const char* name;
  const char* content;
  std::size_t line;
  const char* message_part;
};

class GraphIoBadInput : public ::testing::TestWithParam<BadInput> {};

constexpr const char* kTwoNodes = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";

TEST_P(GraphIoBadInput, FailsWithFileLineAndReason) {
  const BadInput& bad = GetParam();
  TempDir dir;
  const std::string path = dir.file(std::string(bad.name) + ".g2o", bad.content);
  try {
    readPoseGraph(path);
    FAIL() << "no error for " << bad.name;
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), path);
    EXPECT_EQ(e.line(), bad.line) << e.what();
    EXPECT_NE(std::string(e.what()).find(bad.message_part), std::string::npos) << e.what();
    if (bad.line > 0) {
      EXPECT_NE(std::string(e.what()).find(path + ":" + std::to_string(bad.line) + ":"),
                std::string::npos);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllKinds, GraphIoBadInput,
    ::testing::Values(
        BadInput{"unknown_tag", "VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n", 2,
                 "unknown tag"},
        BadInput{"field_count", "VERTEX_SE2 0 0 0\n", 1, "expects 4 fields"},
        BadInput{"edge_field_count",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", 3,
                 "expects 11 fields"},
        BadInput{"non_numeric", "VERTEX_SE2 0 0 abc 0\n", 1, "'abc') is not a number"},
        BadInput{"bad_id", "VERTEX_SE2 -3 0 0 0\n", 1, "not a node id"},
        BadInput{"nan", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 nan 0 0\n", 2, "not finite"},
        BadInput{"inf",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 inf 0 0 1 0 1\n", 3,
                 "not finite"},
        BadInput{"not_pd",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n", 3,
                 "not positive definite"},
        BadInput{"zero_info",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n", 3,
                 "not positive definite"},
        BadInput{"unknown_node",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n", 3,
                 "unknown node 7"},
        BadInput{"duplicate_vertex", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX2 1 1 0 0\n", 3,
                 "duplicate vertex id 1 (first defined on line 2)"},
        BadInput{"self_loop",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 1 1 0 0 0 1 0 0 1 0 1\n", 3,
                 "self-loop"},
        BadInput{"disconnected",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SE2 3 3 0 0\n"
                 "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 2 3 1 0 0 1 0 0 1 0 1\n",
                 0, "2 components: {0..1} (2 nodes), {2..3} (2 nodes)"},
        BadInput{"empty", "# nothing but a comment\n", 0, "no vertices or edges"},
        // Dense factors (RRR_DENSE_SE2: 2 nodes, 1 measurement, 3 means, 6 entries, offset).
        BadInput{"dense_count", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nRRR_DENSE_SE2 1 0\n", 3,
                 "node count 1"},
        BadInput{"dense_fields",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nRRR_DENSE_SE2 2 0 1 1 0 0 0 0 0 1 0 0\n",
                 3, "expects 16 fields"},
        BadInput{"dense_not_pd",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
                 "RRR_DENSE_SE2 2 0 1 1 0 0 0 0 0 1 0 0 -1 0 1 0\n",
                 3, "not positive definite"},
        BadInput{"dense_unknown_node",
                 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
                 "RRR_DENSE_SE2 2 0 9 1 0 0 0 0 0 1 0 0 1 0 1 0\n",
                 4, "unknown node 9"},
        // Found by the fuzzer (test/fuzz/regressions/graph_io): finite steps, infinite chain.
        BadInput{"chained_pose_overflows",
                 "EDGE_SE2 0 1 1e308 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1e308 0 0 1 0 0 1 0 1\n", 2,
                 "gives node 2 a pose that is not finite"}),
    [](const ::testing::TestParamInfo<BadInput>& param_info) {
      return std::string(param_info.param.name);
    });

// A NUL byte is no text: an error naming its line (C string handling would drop the rest of the
// line, and a loop candidate after a comment would vanish).
TEST(GraphIo, NulByteIsAnErrorNamingTheLine) {
  TempDir dir;
  const std::string content = std::string("VERTEX_SE2 0 0 0 0\n# note") + '\0' +
                              "\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  const std::string path = dir.file("nul.g2o", content);
  try {
    readPoseGraph(path);
    FAIL() << "NUL byte accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2u) << e.what();
    EXPECT_NE(std::string(e.what()).find("NUL byte at column 7"), std::string::npos) << e.what();
  }
}

// Lines longer than the reader's buffer, and a last line without its newline.
TEST(GraphIo, LongLinesAndAMissingFinalNewline) {
  TempDir dir;
  const std::string content = "# " + std::string(200000, 'x') +
                              "\nVERTEX_SE2 0 0 0 0\r\nVERTEX_SE2 1 1 0 0\n# " +
                              std::string(70000, 'y') + "\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1";
  const PoseGraph g = readPoseGraph(dir.file("long.g2o", content));
  EXPECT_EQ(g.numNodes(), 2u);
  ASSERT_EQ(g.numEdges(), 1u);
  EXPECT_EQ(g.edge(0).to, 1u);
}

TEST(GraphIo, MissingFileAndTruncatedGzip) {
  EXPECT_THROW(readPoseGraph("/nonexistent/graph.g2o"), InputError);
  TempDir dir;
  const std::string truncated = dir.file("t.g2o.gz");
  {
    std::ifstream in(kData + "/intel.g2o.gz", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_THROW(readPoseGraph(truncated), InputError);
}

TEST(GraphIo, DisconnectedAllowedOnRequest) {
  TempDir dir;
  const std::string path = dir.file("two.g2o", std::string(kTwoNodes) +
                                                   "VERTEX_SE2 5 3 0 0\n"
                                                   "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n");
  GraphReadOptions options;
  options.allow_disconnected = true;
  const PoseGraph g = readPoseGraph(path, options);
  EXPECT_EQ(g.connectedComponents().size(), 2u);
}

TEST(GraphIo, WriteIsAtomicAndLeavesNoTemporaryFiles) {
  TempDir dir;
  const std::string path = dir.file("g.g2o");
  const PoseGraph g = readPoseGraph(kData + "/ring.g2o.gz");
  writePoseGraph(g, path);
  writePoseGraph(g, path);  // overwrite in place
  int files = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(path).parent_path())) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
  EXPECT_THROW(writePoseGraph(g, "/nonexistent/dir/g.g2o"), std::runtime_error);
}

}  // namespace
}  // namespace rrr_graphslam::core
