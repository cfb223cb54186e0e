#pragma once
// Pose graphs shared by the marginalization, Chow-Liu and KL tests: random chains with loop
// closures, away from their minimum (errors and gradients nonzero), and a 40-node loop with
// cross-loop closures, optimized, as a lifelong map would be trimmed. Plus two small helpers.

#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/pose_graph.h"

namespace rrr_graphslam::core::test_graphs {

// A random symmetric positive-definite information: rotated axes, standard deviations of
// 0.02-0.3 m and 0.005-0.05 rad, with some x-theta coupling.
inline Eigen::Matrix3d randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double angle = 2.0 * M_PI * u(rng);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  R.topLeftCorner<2, 2>() << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  R(0, 2) = 0.3 * (u(rng) - 0.5);
  const Eigen::Vector3d sigma(0.02 + 0.28 * u(rng), 0.02 + 0.28 * u(rng), 0.005 + 0.045 * u(rng));
  const Eigen::Matrix3d covariance = R * sigma.cwiseAbs2().asDiagonal() * R.transpose();
  return covariance.inverse();
}

// A chain of `n` nodes (ids 0..n-1, headings anywhere in (-pi, pi], some near +-pi) with
// `closures` random loop closures and one duplicated odometry edge. Measurements are the true
// relative poses plus noise and the graph's poses the truth plus noise, both scaled by `noise`:
// with the default 1 no constraint is satisfied, with 0 all are.
inline PoseGraph randomChainWithLoops(int n, unsigned seed, int closures,
                                      double noise_scale = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_int_distribution<int> node(0, n - 1);
  std::vector<Pose2> truth{Pose2(0.0, 0.0, M_PI - 0.01)};
  for (int k = 1; k < n; ++k) {
    const Pose2 step(1.0 + 0.3 * noise(rng), 0.2 * noise(rng), 0.6 * noise(rng));
    truth.push_back(compose(truth.back(), step));
  }
  auto perturbed = [&](const Pose2& p, double scale) {
    const double s = scale * noise_scale;
    return Pose2(p.x() + s * noise(rng), p.y() + s * noise(rng),
                 normalizeAngle(p.z() + 0.2 * s * noise(rng)));
  };
  PoseGraph graph;
  for (int k = 0; k < n; ++k) graph.addNode(static_cast<NodeId>(k), perturbed(truth[k], 0.05));
  auto addEdge = [&](int from, int to, EdgeKind kind) {
    graph.addEdge(static_cast<NodeId>(from), static_cast<NodeId>(to),
                  perturbed(between(truth[from], truth[to]), 0.02), randomInformation(rng), kind);
  };
  for (int k = 0; k + 1 < n; ++k) addEdge(k, k + 1, EdgeKind::kOdometry);
  addEdge(n / 2, n / 2 + 1, EdgeKind::kOdometry);
  for (int added = 0; added < closures;) {
    const int a = node(rng), b = node(rng);
    if (std::abs(a - b) < 2) continue;
    addEdge(a, b, EdgeKind::kLoopCandidate);
    ++added;
  }
  return graph;
}

inline std::map<NodeId, Pose2> posesOf(const PoseGraph& graph) {
  std::map<NodeId, Pose2> poses;
  for (NodeId id : graph.nodeIds()) poses.emplace(id, graph.pose(id));
  return poses;
}

// A 40-node loop around a thin block: nodes 0..19 eastwards along y = 0, 20..39 back westwards
// along y = 2 m, 1 m apart, closed by 39 -> 0, with closures across the block k <-> 39 - k for
// k = 1, 4, ..., 19 (the laser sees the other side). Odometry sigma 5 cm / 0.01 rad, closures
// 10 cm / 0.02 rad, noise with `seed`; optimized (node 0 fixed) to the minimum's rounding, as a
// map is before trimming.
// Marginalizing 10..19 leaves the blanket {9, 20, 23, 26, 29}.
inline PoseGraph optimizedThinLoop(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<Pose2> truth;
  for (int k = 0; k < 40; ++k) {
    truth.push_back(k < 20 ? Pose2(k, 0.0, 0.0) : Pose2(39 - k, 2.0, M_PI));
  }
  const Eigen::Matrix3d odometry = Eigen::Vector3d(400.0, 400.0, 1e4).asDiagonal();
  const Eigen::Matrix3d closure = Eigen::Vector3d(100.0, 100.0, 2500.0).asDiagonal();
  PoseGraph graph;
  for (int k = 0; k < 40; ++k) graph.addNode(static_cast<NodeId>(k), truth[k]);
  auto addEdge = [&](int from, int to, const Eigen::Matrix3d& information, EdgeKind kind) {
    const Pose2 z = between(truth[from], truth[to]);
    const double sigma_xy = 1.0 / std::sqrt(information(0, 0));
    const double sigma_theta = 1.0 / std::sqrt(information(2, 2));
    graph.addEdge(static_cast<NodeId>(from), static_cast<NodeId>(to),
                  Pose2(z.x() + sigma_xy * noise(rng), z.y() + sigma_xy * noise(rng),
                        normalizeAngle(z.z() + sigma_theta * noise(rng))),
                  information, kind);
  };
  for (int k = 0; k + 1 < 40; ++k) addEdge(k, k + 1, odometry, EdgeKind::kOdometry);
  addEdge(39, 0, odometry, EdgeKind::kLoopCandidate);
  for (int k = 1; k < 20; k += 3) addEdge(k, 39 - k, closure, EdgeKind::kLoopCandidate);
  OptimizerParams params;
  params.relative_tolerance = 1e-15;
  params.step_tolerance = 1e-12;
  Optimizer optimizer = makeOptimizer(graph, params);
  EXPECT_TRUE(optimizer.optimize().converged());
  copyPosesToGraph(optimizer, graph);
  return graph;
}

// Ids first, first + 1, ..., first + count - 1.
inline std::vector<NodeId> run(int first, int count) {
  std::vector<NodeId> ids;
  for (int k = first; k < first + count; ++k) ids.push_back(static_cast<NodeId>(k));
  return ids;
}

inline void expectInvalidArgumentMentioning(const std::function<void()>& call,
                                            const std::string& text) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one mentioning \"" << text << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

}  // namespace rrr_graphslam::core::test_graphs
