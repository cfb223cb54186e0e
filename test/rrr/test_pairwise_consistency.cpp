// The pairwise cycle test: its chi2 follows chi2(3) for true pairs (Monte Carlo, with odometry
// pieces apart and sharing steps), false pairs fail it, and a mixed cluster splits into pure
// groups.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/rrr/pairwise_consistency.h"

namespace rrr_graphslam::rrr {
namespace {

// A robot driving a wavy path that crosses itself often enough for short loops: true poses.
std::vector<core::Pose2> wavyPath(int n) {
  std::vector<core::Pose2> poses;
  for (int k = 0; k < n; ++k) {
    const double t = 0.25 * k;
    poses.emplace_back(3.0 * std::sin(t), 2.0 * std::sin(2.0 * t), 0.0);
  }
  for (int k = 0; k + 1 < n; ++k) {
    const core::Pose2 d = poses[k + 1] - poses[k];
    poses[k](2) = std::atan2(d(1), d(0));
  }
  poses[n - 1](2) = poses[n - 2](2);
  return poses;
}

// Two laps of a 15 m square, 1 m steps: node k + 60 is where node k was.
std::vector<core::Pose2> squareLaps() {
  std::vector<core::Pose2> poses;
  for (int k = 0; k < 120; ++k) {
    const int side = (k / 15) % 4, along = k % 15;
    const double x[] = {double(along), 15.0, 15.0 - along, 0.0};
    const double y[] = {0.0, double(along), 15.0, 15.0 - along};
    poses.emplace_back(x[side], y[side], core::normalizeAngle(side * M_PI / 2));
  }
  return poses;
}

struct Noise {
  Eigen::Matrix3d odometry = Eigen::Vector3d(0.02, 0.02, 0.01).cwiseAbs2().asDiagonal();
  Eigen::Matrix3d loop = Eigen::Vector3d(0.01, 0.01, 0.005).cwiseAbs2().asDiagonal();
};

core::Pose2 noisy(const core::Pose2& z, const Eigen::Matrix3d& covariance, std::mt19937& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const Eigen::Vector3d n(unit(rng), unit(rng), unit(rng));
  const Eigen::Matrix3d L = covariance.llt().matrixL();
  return core::compose(z, L * n);  // noise on the right, as g2o
}

// One sample: noisy odometry along the path and the given loops (from, to) measured with noise;
// the last `num_false` loops are displaced by 0.5 m, or all measure `false_z` if given.
VerificationGraph sampleGraph(const std::vector<core::Pose2>& truth,
                              const std::vector<std::pair<int, int>>& loops, const Noise& noise,
                              std::mt19937& rng, std::size_t num_false = 0,
                              const std::optional<core::Pose2>& false_z = std::nullopt) {
  core::PoseGraph g;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    g.addNode(static_cast<core::PoseGraph::NodeId>(k), truth[k]);
    if (k > 0) {
      g.addEdge(k - 1, k, noisy(core::between(truth[k - 1], truth[k]), noise.odometry, rng),
                noise.odometry.inverse(), core::EdgeKind::kOdometry);
    }
  }
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const auto [a, b] = loops[i];
    core::Pose2 z = noisy(core::between(truth[a], truth[b]), noise.loop, rng);
    if (i + num_false >= loops.size()) {
      z = false_z ? noisy(*false_z, noise.loop, rng)
                  : core::compose(z, core::Pose2(0.5, -0.3, 0.05));
    }
    g.addEdge(a, b, z, noise.loop.inverse(), core::EdgeKind::kLoopCandidate);
  }
  return VerificationGraph(g, {});
}

double meanChi2(const std::vector<std::pair<int, int>>& pair, int samples) {
  const std::vector<core::Pose2> truth = wavyPath(60);
  std::mt19937 rng(11);
  double sum = 0.0;
  for (int s = 0; s < samples; ++s) {
    const VerificationGraph graph = sampleGraph(truth, pair, Noise{}, rng);
    const std::optional<double> d2 = pairwiseCycleChi2(graph, 0, 1);
    EXPECT_TRUE(d2.has_value());
    EXPECT_EQ(*d2, *pairwiseCycleChi2(graph, 1, 0));  // symmetric
    sum += d2.value_or(0.0);
  }
  return sum / samples;
}

TEST(PairwiseConsistency, TruePairsFollowChiSquareThree) {
  // Mean of chi2(3) is 3; over 2000 samples its standard error is 0.055.
  // Odometry pieces 30..32 and 8..10, apart:
  EXPECT_NEAR(meanChi2({{8, 30}, {10, 32}}, 2000), 3.0, 0.25);
  // Pieces 13..18 and 10..15 share steps 13..15, travelled both ways round the cycle: treated as
  // independent, the cycle's covariance would be too large and the mean well below 3.
  EXPECT_NEAR(meanChi2({{10, 13}, {15, 18}}, 2000), 3.0, 0.25);
  // Links given in opposite directions are paired end to end all the same.
  EXPECT_NEAR(meanChi2({{8, 30}, {32, 10}}, 2000), 3.0, 0.25);
}

TEST(PairwiseConsistency, FalsePairFailsAndSessionsAreUntestable) {
  const std::vector<core::Pose2> truth = wavyPath(60);
  std::mt19937 rng(5);
  const VerificationGraph graph = sampleGraph(truth, {{8, 30}, {10, 32}}, Noise{}, rng, 1);
  EXPECT_GT(*pairwiseCycleChi2(graph, 0, 1), 10.0 * core::chi2Quantile(0.95, 3));

  // Two sessions (no odometry between nodes 29 and 30): a cycle through 8 -> 30 and 31 -> 10
  // has its odometry within sessions; one through 8 -> 30 and 10 -> 28 has not.
  core::PoseGraph g;
  for (int k = 0; k < 40; ++k) {
    g.addNode(static_cast<core::PoseGraph::NodeId>(k), truth[k]);
    if (k > 0 && k != 30) {
      g.addEdge(k - 1, k, core::between(truth[k - 1], truth[k]), Noise{}.odometry.inverse(),
                core::EdgeKind::kOdometry);
    }
  }
  for (auto [a, b] : {std::pair{8, 30}, std::pair{31, 10}, std::pair{10, 28}}) {
    g.addEdge(a, b, core::between(truth[a], truth[b]), Noise{}.loop.inverse(),
              core::EdgeKind::kLoopCandidate);
  }
  const VerificationGraph sessions(g, {});
  ASSERT_EQ(sessions.chain().numSessions(), 2);
  ASSERT_TRUE(pairwiseCycleChi2(sessions, 0, 1).has_value());
  EXPECT_LT(*pairwiseCycleChi2(sessions, 0, 1), 1e-6);
  EXPECT_FALSE(pairwiseCycleChi2(sessions, 0, 2).has_value());
}

TEST(PairwiseConsistency, MixedClusterSplitsIntoPureGroups) {
  // On the second lap along the first side, 5 true links to the first lap and, next to them, 7
  // false ones that all claim "same place" three nodes ahead (a place recognizer fooled along a
  // corridor): more false links than true, each set consistent within itself.
  const std::vector<core::Pose2> truth = squareLaps();
  std::vector<std::pair<int, int>> loops;
  for (int k = 0; k < 5; ++k) loops.emplace_back(2 + k, 62 + k);
  for (int k = 0; k < 7; ++k) loops.emplace_back(2 + k, 65 + k);
  std::mt19937 rng(2);
  const VerificationGraph graph =
      sampleGraph(truth, loops, Noise{}, rng, 7, core::Pose2(0.05, 0.02, 0.01));
  std::vector<int> all(loops.size());
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
  const auto groups = splitByPairwiseConsistency(graph, all, 0.95);
  // Each pair fails its 95% test by chance one time in twenty, so a true link may end up on
  // its own; but no group mixes true and false links, and the false ones stay together.
  ASSERT_GE(groups.size(), 2U);
  EXPECT_EQ(groups[0], (std::vector<int>{5, 6, 7, 8, 9, 10, 11}));  // largest first
  for (std::size_t g = 1; g < groups.size(); ++g) {
    for (int k : groups[g]) EXPECT_LT(k, 5);
  }
  EXPECT_GE(groups[1].size(), 4U);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
