// The optimizer against a dense Gauss-Newton step, on synthetic loops, and on the vertigo graphs
// against g2o's converged chi-square.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <random>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

// J covariance(J's nodes) J': projectedCovariance's slow, obvious version.
Eigen::MatrixXd denseProjection(const Optimizer& opt,
                                const std::vector<Optimizer::JacobianBlock>& J, int rows) {
  std::vector<int> nodes;
  for (const auto& b : J) nodes.push_back(b.node);
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  Eigen::MatrixXd dense =
      Eigen::MatrixXd::Zero(3 * rows, 3 * static_cast<Eigen::Index>(nodes.size()));
  for (const auto& b : J) {
    const auto at = std::lower_bound(nodes.begin(), nodes.end(), b.node) - nodes.begin();
    dense.block<3, 3>(3 * b.row, 3 * at) += b.value;
  }
  return dense * opt.covariance(nodes) * dense.transpose();
}

// Loop-link Jacobians at the optimizer's poses between the pairs given, one block row each.
std::vector<Optimizer::JacobianBlock> linkJacobians(const Optimizer& opt,
                                                    const std::vector<std::pair<int, int>>& pairs) {
  std::vector<Optimizer::JacobianBlock> J;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto [a, b] = pairs[i];
    const Pose2& pa = opt.poses()[static_cast<std::size_t>(a)];
    const Pose2& pb = opt.poses()[static_cast<std::size_t>(b)];
    const EdgeLinearization lin = linearizeEdge(pa, pb, between(pa, pb));
    J.push_back({static_cast<int>(i), a, lin.J_from});
    J.push_back({static_cast<int>(i), b, lin.J_to});
  }
  return J;
}

// A square loop of `n` poses per side with odometry and a few loop closures; returns the
// optimizer with ground truth in `truth` and a perturbed start.
Optimizer squareLoop(int per_side, std::vector<Pose2>& truth, unsigned seed, double noise) {
  truth.clear();
  Pose2 p(0, 0, 0);
  for (int side = 0; side < 4; ++side) {
    for (int k = 0; k < per_side; ++k) {
      truth.push_back(p);
      p = compose(p, Pose2(1.0, 0.0, k == per_side - 1 ? M_PI / 2 : 0.0));
    }
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Optimizer opt;
  for (const Pose2& t : truth) {
    // Node 0 is the gauge: it starts at the truth so the solution is the truth itself.
    const double scale = opt.numNodes() == 0 ? 0.0 : noise;
    opt.addNode(t + scale * Pose2(n01(rng), n01(rng), 0.3 * n01(rng)));
  }
  Eigen::Matrix3d info = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  info(0, 1) = info(1, 0) = 5.0;
  const int n = static_cast<int>(truth.size());
  for (int i = 0; i + 1 < n; ++i)
    opt.addConstraint(i, i + 1, between(truth[i], truth[i + 1]), info);
  opt.addConstraint(n - 1, 0, between(truth[n - 1], truth[0]), info);
  opt.addConstraint(0, 2 * per_side, between(truth[0], truth[2 * per_side]), info);
  return opt;
}

TEST(Optimizer, SingleStepMatchesDenseSolve) {
  std::vector<Pose2> truth;
  Optimizer opt = squareLoop(5, truth, 7, 0.2);
  // One Gauss-Newton step computed densely and obviously, from the same constraints.
  struct C {
    int i, j;
    Pose2 z;
    Eigen::Matrix3d info;
  };
  std::vector<C> cs;
  const int n = static_cast<int>(truth.size());
  Eigen::Matrix3d info = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  info(0, 1) = info(1, 0) = 5.0;
  for (int i = 0; i + 1 < n; ++i) cs.push_back({i, i + 1, between(truth[i], truth[i + 1]), info});
  cs.push_back({n - 1, 0, between(truth[n - 1], truth[0]), info});
  cs.push_back({0, 10, between(truth[0], truth[10]), info});

  const std::vector<Pose2> start = opt.poses();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * n);
  for (const C& c : cs) {
    const EdgeLinearization lin = linearizeEdge(start[c.i], start[c.j], c.z);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3, 3 * n);
    J.block<3, 3>(0, 3 * c.i) = lin.J_from;
    J.block<3, 3>(0, 3 * c.j) = lin.J_to;
    H += J.transpose() * c.info * J;
    g += J.transpose() * c.info * lin.error;
  }
  const Eigen::MatrixXd H_free = H.bottomRightCorner(3 * (n - 1), 3 * (n - 1));
  const Eigen::VectorXd step = H_free.ldlt().solve(-g.tail(3 * (n - 1)));

  opt.params().max_iterations = 1;
  opt.optimize();
  EXPECT_LT((opt.poses()[0] - start[0]).norm(), 1e-15) << "gauge node moved";
  for (int k = 1; k < n; ++k) {
    Pose2 expected = start[k] + step.segment<3>(3 * (k - 1));
    expected.z() = normalizeAngle(expected.z());
    Pose2 d = opt.poses()[k] - expected;
    d.z() = normalizeAngle(d.z());
    EXPECT_LT(d.norm(), 1e-9) << "node " << k;
  }
}

TEST(Optimizer, ConvergesFromPerturbedStartGnAndLm) {
  for (auto method :
       {OptimizerParams::Method::kGaussNewton, OptimizerParams::Method::kLevenbergMarquardt}) {
    std::vector<Pose2> truth;
    Optimizer opt = squareLoop(10, truth, 3, 0.3);
    opt.params().method = method;
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kConverged);
    EXPECT_GT(r.initial_chi2, 1e3);
    EXPECT_LT(r.final_chi2, 1e-12);
    for (std::size_t k = 0; k < truth.size(); ++k) {
      Pose2 d = opt.poses()[k] - truth[k];
      d.z() = normalizeAngle(d.z());
      EXPECT_LT(d.norm(), 1e-6) << k;
    }
  }
}

TEST(Optimizer, RequestSetsStartMethodAndLimitsForOneCallOnly) {
  std::vector<Pose2> truth;
  Optimizer opt = squareLoop(10, truth, 3, 0.3);
  const std::vector<Pose2> start = opt.poses();
  // One step of Levenberg-Marquardt from the start: not converged, the settings untouched.
  OptimizationRequest one_lm_step = startFrom(start);
  one_lm_step.method = OptimizerParams::Method::kLevenbergMarquardt;
  one_lm_step.max_iterations = 1;
  const OptimizationResult first = opt.optimize(one_lm_step);
  EXPECT_EQ(first.stop_reason, StopReason::kMaxIterations);
  EXPECT_EQ(first.iterations, 1);
  EXPECT_EQ(opt.params().method, OptimizerParams::Method::kGaussNewton);
  EXPECT_EQ(opt.params().max_iterations, OptimizerParams{}.max_iterations);
  // A default request warm-starts from where that step ended and converges with params().
  const OptimizationResult rest = opt.optimize(OptimizationRequest{});
  EXPECT_EQ(rest.stop_reason, StopReason::kConverged);
  EXPECT_DOUBLE_EQ(rest.initial_chi2, first.final_chi2);
  EXPECT_LT(rest.final_chi2, 1e-12);
  // The same start again gives the same first step.
  EXPECT_DOUBLE_EQ(opt.optimize(one_lm_step).final_chi2, first.final_chi2);
  // A start of the wrong size is refused before anything changes.
  const std::vector<Pose2> short_start(3, Pose2::Zero());
  EXPECT_THROW(opt.optimize(startFrom(short_start)), std::invalid_argument);
  EXPECT_EQ(opt.params().max_iterations, OptimizerParams{}.max_iterations);
}

TEST(Optimizer, SwitchingEdgesOffKeepsTheOrderingAndWarmStartMatchesColdStart) {
  PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  Optimizer opt = makeOptimizer(graph);
  // Start with every loop switched off except 10, then switch 10 more on.
  std::vector<int> loops;
  for (int c = 0; c < opt.numConstraints(); ++c) {
    if (graph.edge(static_cast<std::size_t>(c)).kind == EdgeKind::kLoopCandidate)
      loops.push_back(c);
  }
  for (int c : loops) opt.setActive(c, true);
  opt.optimize();
  EXPECT_EQ(opt.symbolicAnalyses(), 1);
  for (std::size_t k = 0; k < 10; ++k) opt.setActive(loops[k], false);
  const OptimizationResult warm = opt.optimize();
  EXPECT_EQ(opt.symbolicAnalyses(), 1) << "switching edges off must keep the ordering";
  EXPECT_EQ(warm.stop_reason, StopReason::kConverged);
  for (std::size_t k = 0; k < 10; ++k) opt.setActive(loops[k], true);
  opt.optimize();
  EXPECT_EQ(opt.symbolicAnalyses(), 1) << "edges back on, still inside the pattern";

  // The same active set optimized from the initial guess reaches the same chi-square.
  Optimizer cold = makeOptimizer(graph);
  for (std::size_t k = 0; k < 10; ++k) cold.setActive(loops[k], false);
  const OptimizationResult cold_result = cold.optimize();
  EXPECT_NEAR(warm.final_chi2, cold_result.final_chi2, 1e-6 * cold_result.final_chi2);
}

TEST(Optimizer, RankUpdatedFactorReachesTheColdStartChi2WithoutFactorizing) {
  PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  OptimizerParams params;
  params.factor_updates = true;
  Optimizer opt = makeOptimizer(graph, params);
  std::vector<int> loops;
  for (int c = 0; c < opt.numConstraints(); ++c) {
    if (graph.edge(static_cast<std::size_t>(c)).kind == EdgeKind::kLoopCandidate)
      loops.push_back(c);
  }
  // From the file's estimate; then once more from the optimum, so that the factor the updates
  // start from is linearized there (a run's factor is from its last factorization).
  auto converge = [](Optimizer& o) {
    o.optimize();
    const bool updates = o.params().factor_updates;
    o.params().factor_updates = false;
    o.optimize();
    o.params().factor_updates = updates;
  };
  converge(opt);
  ASSERT_TRUE(opt.covarianceAvailable());
  for (std::size_t k = 0; k < 10; ++k) opt.setActive(loops[3 * k], false);
  const OptimizationResult off = opt.optimize();
  EXPECT_EQ(off.factor_updates, 10);
  EXPECT_EQ(off.stop_reason, StopReason::kConverged);
  for (std::size_t k = 0; k < 10; ++k) opt.setActive(loops[3 * k], true);
  const OptimizationResult on = opt.optimize();
  EXPECT_EQ(on.factor_updates, 10);
  EXPECT_EQ(on.factorizations, 0) << "a converged graph plus ten true loops: chord steps suffice";
  ASSERT_TRUE(opt.covarianceAvailable()) << "the updated factor serves covariance()";
  {
    Optimizer fresh = makeOptimizer(graph);
    converge(fresh);
    const std::vector<int> nodes{100, 500, 900};  // of 943
    const Eigen::MatrixXd reference = fresh.covariance(nodes);
    EXPECT_LT((opt.covariance(nodes) - reference).norm(), 1e-3 * reference.norm());
  }

  for (const bool all_on : {false, true}) {
    Optimizer cold = makeOptimizer(graph);
    for (std::size_t k = 0; k < 10 && !all_on; ++k) cold.setActive(loops[3 * k], false);
    const double reference = cold.optimize().final_chi2;
    EXPECT_NEAR((all_on ? on : off).final_chi2, reference, 1e-5 * reference);
  }
  // Too many changes for updates: a plain factorization.
  opt.params().max_factor_updates = 5;
  for (std::size_t k = 0; k < 10; ++k) opt.setActive(loops[3 * k], false);
  const OptimizationResult many = opt.optimize();
  EXPECT_EQ(many.factor_updates, 0);
  EXPECT_GE(many.factorizations, 1);
}

TEST(Optimizer, ConstraintsNewToThePatternAreFoldedInByRankUpdates) {
  // Intel without its last ten loops, optimized; then the loops arrive as new constraints.
  PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  std::vector<std::size_t> late;
  for (std::size_t e = graph.numEdges(); e-- > 0 && late.size() < 10;) {
    if (graph.edge(e).kind == EdgeKind::kLoopCandidate) late.push_back(e);
  }
  OptimizerParams params;
  params.factor_updates = true;
  Optimizer opt(params);
  std::unordered_map<PoseGraph::NodeId, int> index;
  for (PoseGraph::NodeId id : graph.nodeIds()) index.emplace(id, opt.addNode(graph.pose(id)));
  auto add = [&](std::size_t e) {
    opt.addConstraint(index.at(graph.edge(e).from), index.at(graph.edge(e).to),
                      graph.measurement(e), graph.information(e));
  };
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    if (std::find(late.begin(), late.end(), e) == late.end()) add(e);
  }
  opt.optimize();
  for (std::size_t e : late) add(e);
  const OptimizationResult r = opt.optimize();
  EXPECT_EQ(r.factor_updates, 10);
  EXPECT_EQ(opt.symbolicAnalyses(), 1) << "the pattern waits for the next fresh factorization";
  Optimizer cold = makeOptimizer(graph);
  const double reference = cold.optimize().final_chi2;
  EXPECT_NEAR(r.final_chi2, reference, 1e-5 * reference);

  // A fresh factorization (updates off) rebuilds the pattern with the new constraints in it.
  opt.params().factor_updates = false;
  opt.setPoses(cold.poses());
  const OptimizationResult again = opt.optimize();
  EXPECT_EQ(opt.symbolicAnalyses(), 2);
  EXPECT_NEAR(again.final_chi2, reference, 1e-5 * reference);
}

// A robot's graph grows by nodes hanging from the newest by odometry; the factor of the graph
// before them still gives every marginal, the new nodes' by propagation through odometry.
TEST(Optimizer, CovarianceCoversNodesAddedByOdometryAfterTheFactorization) {
  PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  const std::vector<PoseGraph::NodeId> ids = graph.nodeIds();
  std::unordered_map<PoseGraph::NodeId, int> index;
  for (std::size_t n = 0; n < ids.size(); ++n) index.emplace(ids[n], static_cast<int>(n));
  const int factored = 700;  // of 943
  Optimizer grown;
  for (int n = 0; n < factored; ++n) grown.addNode(graph.pose(ids[static_cast<std::size_t>(n)]));
  std::vector<std::size_t> later;  // edges reaching past the factored nodes
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    const int a = index.at(graph.edge(e).from), b = index.at(graph.edge(e).to);
    if (std::max(a, b) >= factored) {
      later.push_back(e);
      continue;
    }
    grown.addConstraint(a, b, graph.measurement(e), graph.information(e));
  }
  grown.optimize();
  grown.optimize();  // a factorization at the minimum
  ASSERT_TRUE(grown.covarianceAvailable());

  // New nodes on their odometry from the optimized end; the loops reaching them stay off.
  std::vector<int> loops;
  std::vector<Pose2> poses = grown.poses();
  for (int n = factored; n < static_cast<int>(ids.size()); ++n) {
    grown.addNode(Pose2::Zero());
    for (std::size_t e : later) {
      const int a = index.at(graph.edge(e).from), b = index.at(graph.edge(e).to);
      if (std::max(a, b) != n) continue;
      const bool odometry = graph.edge(e).kind == EdgeKind::kOdometry;
      const int c = grown.addConstraint(a, b, graph.measurement(e), graph.information(e), odometry);
      if (!odometry) loops.push_back(c);
      if (odometry) {
        poses.push_back(
            b == n ? compose(poses[static_cast<std::size_t>(a)], graph.measurement(e))
                   : compose(poses[static_cast<std::size_t>(b)], inverse(graph.measurement(e))));
      }
    }
  }
  ASSERT_EQ(poses.size(), ids.size());
  grown.setPoses(poses);
  ASSERT_TRUE(grown.covarianceAvailable()) << "odometry-only growth keeps the factor's marginals";

  // Reference: the same active set factorized afresh at the same (optimal) poses.
  Optimizer fresh;
  for (const Pose2& p : poses) fresh.addNode(p);
  for (int c = 0; c < grown.numConstraints(); ++c) {
    fresh.addConstraint(grown.from(c), grown.to(c), grown.measurement(c), grown.information(c),
                        grown.isActive(c));
  }
  fresh.optimize();
  ASSERT_TRUE(fresh.covarianceAvailable());
  const std::vector<int> nodes{100, 699, 700, 820, 942};
  const Eigen::MatrixXd reference = fresh.covariance(nodes);
  EXPECT_LT((grown.covariance(nodes) - reference).norm(), 1e-4 * reference.norm());
  const std::vector<int> new_only{942, 800};
  EXPECT_LT((grown.covariance(new_only) - fresh.covariance(new_only)).norm(),
            1e-4 * reference.norm());
  // A link to a node added since goes through the propagated joint covariance.
  const std::vector<Optimizer::JacobianBlock> J = linkJacobians(grown, {{100, 942}, {699, 820}});
  EXPECT_LT((grown.projectedCovariance(J, 2) - denseProjection(fresh, J, 2)).norm(),
            1e-4 * denseProjection(fresh, J, 2).norm());

  // A loop switched on among the new nodes changes the marginals: no longer available.
  ASSERT_FALSE(loops.empty());
  grown.setActive(loops.front(), true);
  EXPECT_FALSE(grown.covarianceAvailable());
}

// With factor updates a growing graph keeps its factor: each new node takes a variable slot
// reserved at the end of the ordering, and its odometry comes in by a rank update.
TEST(Optimizer, NodesOnReservedSlotsJoinTheFactorByRankUpdates) {
  PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  const std::vector<PoseGraph::NodeId> ids = graph.nodeIds();
  std::unordered_map<PoseGraph::NodeId, int> index;
  for (std::size_t n = 0; n < ids.size(); ++n) index.emplace(ids[n], static_cast<int>(n));
  OptimizerParams params;
  params.factor_updates = true;
  params.reserved_slots = 50;
  params.max_factor_updates = 64;
  Optimizer grown(params);
  std::vector<int> loops;  // constraints of loops reaching the new nodes (off)
  int added_nodes = 0;
  // Node n with the edges whose newest end it is: odometry on, loops off; a new node starts on
  // its odometry from the current estimate.
  // Nodes up to `last` with the edges whose newest end they are: odometry on, loops beyond node
  // 700 off. Nodes up to 700 start at the file's poses, later ones on their odometry from the
  // current estimate.
  auto addUpTo = [&](int last) {
    std::vector<Pose2> poses = grown.poses();
    for (int n = grown.numNodes(); n <= last; ++n) {
      grown.addNode(Pose2::Zero());
      if (n < 700) poses.push_back(graph.pose(ids[static_cast<std::size_t>(n)]));
      for (std::size_t e = 0; e < graph.numEdges(); ++e) {
        const int a = index.at(graph.edge(e).from), b = index.at(graph.edge(e).to);
        if (std::max(a, b) != n) continue;
        const bool odometry = graph.edge(e).kind == EdgeKind::kOdometry;
        const int c = grown.addConstraint(a, b, graph.measurement(e), graph.information(e),
                                          odometry || n < 700);
        if (!odometry && n >= 700) loops.push_back(c);
        if (odometry && n >= 700) {
          poses.push_back(
              b == n ? compose(poses[static_cast<std::size_t>(a)], graph.measurement(e))
                     : compose(poses[static_cast<std::size_t>(b)], inverse(graph.measurement(e))));
        }
      }
      if (n >= 700) ++added_nodes;
    }
    ASSERT_EQ(poses.size(), static_cast<std::size_t>(grown.numNodes()));
    grown.setPoses(poses);
  };
  addUpTo(699);
  grown.optimize();
  grown.optimize();  // a factorization at the minimum
  ASSERT_TRUE(grown.covarianceAvailable());
  const int analyses = grown.symbolicAnalyses();

  // A fresh optimizer of the same active set at the same poses: the reference.
  auto fresh = [&] {
    Optimizer f;
    for (const Pose2& p : grown.poses()) f.addNode(p);
    for (int c = 0; c < grown.numConstraints(); ++c) {
      f.addConstraint(grown.from(c), grown.to(c), grown.measurement(c), grown.information(c),
                      grown.isActive(c));
    }
    return f;
  };

  // 40 nodes on odometry: already at their minimum, folded in by rank updates alone.
  addUpTo(739);
  ASSERT_EQ(added_nodes, 40);
  OptimizationResult r = grown.optimize();
  EXPECT_EQ(r.factor_updates, 40);
  EXPECT_EQ(r.factorizations, 0);
  EXPECT_EQ(grown.symbolicAnalyses(), analyses) << "the new nodes took reserved slots";
  ASSERT_TRUE(grown.covarianceAvailable());
  {
    Optimizer reference = fresh();
    reference.optimize();
    const std::vector<int> nodes{100, 699, 720, 739};
    const Eigen::MatrixXd expected = reference.covariance(nodes);
    EXPECT_LT((grown.covariance(nodes) - expected).norm(), 1e-4 * expected.norm())
        << "the covariance is read from the factor the slots joined";
  }

  // A loop among the new nodes: one more update, and the cold start's minimum.
  ASSERT_FALSE(loops.empty());
  grown.setActive(loops.front(), true);
  r = grown.optimize();
  EXPECT_EQ(r.factor_updates, 1);
  EXPECT_EQ(grown.symbolicAnalyses(), analyses);
  {
    Optimizer reference = fresh();
    const double chi2 = reference.optimize().final_chi2;
    EXPECT_NEAR(r.final_chi2, chi2, 1e-4 * chi2 + 1e-9);
  }

  // Past the reserve (50 slots): a new pattern, and the same minimum as a cold start.
  addUpTo(759);
  r = grown.optimize();
  EXPECT_EQ(r.factor_updates, 0);
  EXPECT_GE(r.factorizations, 1);
  EXPECT_EQ(grown.symbolicAnalyses(), analyses + 1);
  Optimizer reference = fresh();
  const double chi2 = reference.optimize().final_chi2;
  EXPECT_NEAR(r.final_chi2, chi2, 1e-4 * chi2 + 1e-9);
}

TEST(Lago, StartsFarOffGraphsNearTheirMinimum) {
  Optimizer m3500 = makeOptimizer(readPoseGraph(kData + "/manhattanOlson3500_olson.g2o.gz"));
  EXPECT_TRUE(farFromMinimum(m3500)) << "the file's estimate: 458 per constraint";
  m3500.setPoses(lagoInitialization(m3500));
  EXPECT_FALSE(farFromMinimum(m3500));
  EXPECT_LT(m3500.chi2(), 1.5 * 146.077);
  const OptimizationResult r = m3500.optimize();
  EXPECT_NEAR(r.final_chi2, 146.077, 1e-3 * 146.077);
  EXPECT_LE(r.iterations, 4);

  // Intel's file estimate is already close (0.7 per constraint): nothing to gain there.
  EXPECT_FALSE(farFromMinimum(makeOptimizer(readPoseGraph(kData + "/intel.g2o.gz"))));
}

TEST(Lago, KeepsTheFixedNodesWhereTheyAre) {
  // A square loop whose first side is fixed away from the origin (a loaded map held still):
  // LAGO's estimate leaves those nodes where they are and places the rest around them.
  std::vector<Pose2> truth;
  Optimizer opt = squareLoop(5, truth, 3, 0.3);
  const Pose2 frame(10.0, -4.0, 0.7);
  std::vector<Pose2> start = opt.poses();
  for (int k = 0; k < 5; ++k) {
    start[static_cast<std::size_t>(k)] = compose(frame, truth[static_cast<std::size_t>(k)]);
    opt.setFixed(k, true);
  }
  opt.setPoses(start);
  const std::vector<Pose2> lago = lagoInitialization(opt);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(lago[k], start[k]) << "fixed node " << k;
  for (std::size_t k = 5; k < truth.size(); ++k) {
    const Pose2 expected = compose(frame, truth[k]);
    EXPECT_LT((lago[k].head<2>() - expected.head<2>()).norm(), 0.05) << "node " << k;
    EXPECT_LT(std::abs(normalizeAngle(lago[k].z() - expected.z())), 0.01) << "node " << k;
  }
}

TEST(Optimizer, UnanchoredComponentsAreHeldByWeakPriors) {
  // Two sessions: two odometry chains with no link between them.
  Optimizer opt;
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity() * 10.0;
  for (int k = 0; k < 6; ++k) opt.addNode(Pose2(k, 0.1 * k, 0));
  opt.addConstraint(0, 1, Pose2(1, 0, 0), info);
  opt.addConstraint(1, 2, Pose2(1, 0, 0), info);
  opt.addConstraint(3, 4, Pose2(1, 0, 0), info);
  opt.addConstraint(4, 5, Pose2(1, 0, 0), info);
  const int link = opt.addConstraint(2, 3, Pose2(1, 0, 0), info, false);
  OptimizationResult r = opt.optimize();
  EXPECT_EQ(r.stop_reason, StopReason::kConverged);
  EXPECT_LT(r.final_chi2, 1e-9);
  EXPECT_NEAR(opt.poses()[3].y(), 0.3, 1e-6) << "second session stays where it was";
  opt.setActive(link, true);  // a cross-session link joins them
  r = opt.optimize();
  EXPECT_LT(r.final_chi2, 1e-9);
  EXPECT_NEAR(opt.poses()[5].x(), 5.0, 1e-6);
  EXPECT_NEAR(opt.poses()[5].y(), 0.0, 1e-6);
}

// Every way optimize() can end reaches the caller as a stop reason, and only a minimum counts
// as converged.
TEST(Optimizer, StopReasonsReachTheCaller) {
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity() * 100.0;
  auto chain = [&](const Pose2& far_end) {
    Optimizer opt;
    opt.addNode(Pose2(0, 0, 0));
    opt.addNode(Pose2(1, 0, 0));
    opt.addNode(far_end);
    opt.addConstraint(0, 1, Pose2(1, 0, 0), info);
    opt.addConstraint(1, 2, Pose2(1, 0, 0.1), info);
    opt.addConstraint(0, 2, Pose2(2, 0.1, 0.1), info);
    opt.setFixed(0, true);
    return opt;
  };
  {
    Optimizer opt = chain(Pose2(2.5, 0.3, 0.2));
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kConverged);
    EXPECT_TRUE(r.converged());
  }
  {  // a start whose chi2 is not finite: nothing to judge a step by
    Optimizer opt = chain(Pose2(1e200, 0.0, 0.0));
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kDiverged);
    EXPECT_FALSE(r.converged());
    EXPECT_EQ(opt.poses()[2].x(), 1e200);  // left where it was
  }
  {
    Optimizer opt = chain(Pose2(2.5, 0.3, 0.2));
    opt.params().max_iterations = 1;
    opt.params().relative_tolerance = 0.0;
    opt.params().step_tolerance = 0.0;
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kMaxIterations);
    EXPECT_FALSE(r.converged());
  }
  {
    Optimizer opt = chain(Pose2(2.5, 0.3, 0.2));
    const std::atomic<bool> cancel{true};
    opt.setCancelFlag(&cancel);
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kCancelled);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_FALSE(r.converged());
  }
  {  // node 2 hangs by a constraint of weight 0 only: Gauss-Newton's H is singular
    Optimizer opt;
    opt.addNode(Pose2(0, 0, 0));
    opt.addNode(Pose2(1, 0, 0));
    opt.addConstraint(0, 1, Pose2(1, 0, 0), info);
    opt.setFixed(0, true);
    opt.setWeight(0, 0.0);
    const OptimizationResult r = opt.optimize();
    EXPECT_EQ(r.stop_reason, StopReason::kSingular);
    EXPECT_FALSE(r.converged());
  }
}

// The information matrix built from the constraints, solved for unit vectors by Eigen's own
// sparse LDL^T (the slow, obvious way), gives the marginal covariances the factor's partial
// inverse gives.
TEST(Optimizer, InformationMatrixInvertsToTheMarginalCovariance) {
  const PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  Optimizer opt = makeOptimizer(graph);
  ASSERT_TRUE(opt.optimize().converged());
  ASSERT_TRUE(opt.covarianceAvailable());
  const std::vector<int> nodes{5, 400, 900};  // of 943
  const Eigen::MatrixXd fast = opt.covariance(nodes);
  EXPECT_THROW(opt.covariance({943}), std::out_of_range);
  const Eigen::SparseMatrix<double> H = opt.informationMatrix();
  ASSERT_EQ(H.rows(), 3 * opt.numNodes());
  const Eigen::SparseMatrix<double> asymmetry = H - Eigen::SparseMatrix<double>(H.transpose());
  EXPECT_LT(asymmetry.norm(), 1e-9 * H.norm());
  // Node 0 is fixed: the others' covariance is the inverse of H without its rows and columns.
  const Eigen::Index n = H.rows() - 3;
  const Eigen::SparseMatrix<double> free = H.bottomRightCorner(n, n);
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(free);
  ASSERT_EQ(ldlt.info(), Eigen::Success);
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, 9);
  for (int i = 0; i < 3; ++i) {
    for (int r = 0; r < 3; ++r)
      unit(3 * (nodes[static_cast<std::size_t>(i)] - 1) + r, 3 * i + r) = 1;
  }
  const Eigen::MatrixXd columns = ldlt.solve(unit);
  const double scale = columns.cwiseAbs().maxCoeff();
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    for (std::size_t j = 0; j < nodes.size(); ++j) {
      const Eigen::Matrix3d slow =
          columns.block<3, 3>(3 * (nodes[i] - 1), 3 * static_cast<Eigen::Index>(j));
      const Eigen::Matrix3d got =
          fast.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * static_cast<Eigen::Index>(j));
      // The factor is of the last Gauss-Newton iterate but one: equal to ~1e-4.
      EXPECT_LT((got - slow).cwiseAbs().maxCoeff(), 2e-3 * scale) << nodes[i] << " " << nodes[j];
    }
  }
}

// The covariance of loop links' relative poses read from the factor, one forward solve per
// link row, against the links' Jacobians times the nodes' joint covariance; a link on the fixed
// node 0 and one repeated; nothing without a factorization, out of range for unknown nodes.
TEST(Optimizer, ProjectedCovarianceMatchesTheNodesCovarianceProjected) {
  const PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  Optimizer opt = makeOptimizer(graph);
  const std::vector<std::pair<int, int>> pairs{{10, 700}, {11, 702}, {0, 300}, {10, 700}, {942, 5}};
  const std::vector<Optimizer::JacobianBlock> J = linkJacobians(opt, pairs);
  const int rows = static_cast<int>(pairs.size());
  EXPECT_EQ(opt.projectedCovariance(J, rows).norm(), 0.0) << "no factorization yet";
  ASSERT_TRUE(opt.optimize().converged());
  ASSERT_TRUE(opt.covarianceAvailable());
  const Eigen::MatrixXd expected = denseProjection(opt, J, rows);
  const Eigen::MatrixXd got = opt.projectedCovariance(J, rows);
  ASSERT_EQ(got.rows(), 3 * rows);
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm());
  EXPECT_GT(expected.norm(), 0.0);
  EXPECT_EQ(opt.projectedCovariance({}, 2).norm(), 0.0);
  EXPECT_THROW(opt.projectedCovariance({{0, 943, Eigen::Matrix3d::Identity()}}, 1),
               std::out_of_range);
  EXPECT_THROW(opt.projectedCovariance({{1, 5, Eigen::Matrix3d::Identity()}}, 1),
               std::out_of_range);
  EXPECT_THROW(opt.projectedCovariance({{0, -1, Eigen::Matrix3d::Identity()}}, 1),
               std::out_of_range);
  EXPECT_THROW(opt.projectedCovariance({}, -1), std::out_of_range);
  // Blocks repeated in the same row and node add up.
  std::vector<Optimizer::JacobianBlock> halves = J;
  for (auto& b : halves) b.value *= 0.5;
  halves.insert(halves.end(), halves.begin(), halves.end());
  EXPECT_LT((opt.projectedCovariance(halves, rows) - expected).norm(), 1e-9 * expected.norm());
}

TEST(Optimizer, AFactorizationWhereLevenbergMarquardtStoppedGivesItsCovariance) {
  // Two damped steps from the raw odometry: no covariance, until H is factored where they ended;
  // then exactly the inverse of H there (less node 0, fixed), as Eigen's own simplicial LDLT
  // finds its columns (a dense inverse of Intel's H is 5e10 flops: minutes under the sanitizers).
  const PoseGraph graph = readPoseGraph(kData + "/intel.g2o.gz");
  Optimizer opt = makeOptimizer(graph);
  OptimizationRequest two_damped_steps;
  two_damped_steps.method = OptimizerParams::Method::kLevenbergMarquardt;
  two_damped_steps.max_iterations = 2;
  ASSERT_EQ(opt.optimize(two_damped_steps).stop_reason, StopReason::kMaxIterations);
  EXPECT_FALSE(opt.covarianceAvailable());
  const std::vector<Pose2> stopped = opt.poses();
  ASSERT_TRUE(opt.factorAtCurrentPoses());
  ASSERT_TRUE(opt.covarianceAvailable());
  EXPECT_EQ(opt.poses(), stopped);  // no step taken
  const std::vector<int> nodes{7, 500};
  const Eigen::MatrixXd fast = opt.covariance(nodes);
  const Eigen::SparseMatrix<double> H = opt.informationMatrix();
  const Eigen::Index n = H.rows() - 3;
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> reference(H.bottomRightCorner(n, n));
  ASSERT_EQ(reference.info(), Eigen::Success);
  std::vector<Eigen::MatrixXd> columns;  // the inverse's columns of each node
  for (int node : nodes) {
    Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(n, 3);
    unit.block<3, 3>(3 * (node - 1), 0).setIdentity();
    columns.push_back(reference.solve(unit));
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    for (std::size_t j = 0; j < nodes.size(); ++j) {
      const Eigen::Matrix3d slow = columns[j].block<3, 3>(3 * (nodes[i] - 1), 0);
      const Eigen::Matrix3d got =
          fast.block<3, 3>(3 * static_cast<Eigen::Index>(i), 3 * static_cast<Eigen::Index>(j));
      EXPECT_LT((got - slow).cwiseAbs().maxCoeff(), 1e-6 * slow.cwiseAbs().maxCoeff() + 1e-12);
    }
  }
  opt.setActive(0, false);  // a changed active set: covariance() no longer describes it
  EXPECT_FALSE(opt.covarianceAvailable());
}

TEST(Optimizer, ConstraintChi2OnRequest) {
  std::vector<Pose2> truth;
  Optimizer opt = squareLoop(4, truth, 1, 0.1);
  opt.params().compute_constraint_chi2 = true;
  opt.setActive(opt.numConstraints() - 1, false);
  const OptimizationResult r = opt.optimize();
  ASSERT_EQ(r.constraint_chi2.size(), static_cast<std::size_t>(opt.numConstraints()));
  double sum = 0.0;
  for (int c = 0; c + 1 < opt.numConstraints(); ++c)
    sum += r.constraint_chi2[static_cast<std::size_t>(c)];
  EXPECT_NEAR(sum, r.final_chi2, 1e-9 + 1e-9 * r.final_chi2);
  EXPECT_NEAR(r.constraint_chi2.back(), opt.constraintChi2(opt.numConstraints() - 1), 1e-12);
}

struct Reference {
  const char* file;
  double chi2;
};

class ReferenceChi2 : public ::testing::TestWithParam<Reference> {};

TEST_P(ReferenceChi2, ReachesG2oChi2Within0p1Percent) {
  const Reference ref = GetParam();
  const PoseGraph graph = readPoseGraph(kData + "/" + ref.file);
  for (auto method :
       {OptimizerParams::Method::kGaussNewton, OptimizerParams::Method::kLevenbergMarquardt}) {
    OptimizerParams params;
    params.method = method;
    Optimizer opt = makeOptimizer(graph, params);
    const OptimizationResult r = opt.optimize();
    EXPECT_NEAR(r.final_chi2, ref.chi2, 1e-3 * ref.chi2) << ref.file;
    EXPECT_NEAR(opt.chi2(), r.final_chi2, 1e-9 * r.final_chi2);
    EXPECT_NE(r.stop_reason, StopReason::kSingular);
    EXPECT_NE(r.stop_reason, StopReason::kDiverged);
  }
}

INSTANTIATE_TEST_SUITE_P(Vertigo, ReferenceChi2,
                         ::testing::Values(Reference{"manhattanOlson3500_olson.g2o.gz", 146.077},
                                           Reference{"intel.g2o.gz", 546.461},
                                           Reference{"city10000.g2o.gz", 511.985},
                                           Reference{"ring.g2o.gz", 11.163},
                                           Reference{"ringCity.g2o.gz", 262.818},
                                           Reference{"csail.g2o.gz", 38.956}));

}  // namespace
}  // namespace rrr_graphslam::core
