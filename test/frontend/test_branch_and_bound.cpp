// Branch-and-bound against its definitions: the max-grids equal their brute-force maxima, and the
// search finds the same best pose as scoring every discrete pose of the window.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "rrr_graphslam/frontend/branch_and_bound.h"
#include "rrr_graphslam/frontend/precomputation_grid.h"

namespace rrr_graphslam::frontend {
namespace {

MatchGrid randomGrid(std::mt19937& rng, int width, int height) {
  MatchGrid grid(Eigen::Vector2d(-1.0, -2.0), 0.1, width, height, 0.1F);
  std::uniform_real_distribution<float> value(0.0F, 1.0F);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) grid.set(x, y, value(rng));
  return grid;
}

TEST(MatchGrid, MaxPooledCellsAreTheMaximaOfTheirBlocks) {
  std::mt19937 rng(11);
  const MatchGrid grid = randomGrid(rng, 23, 17);
  for (const int factor : {1, 2, 3}) {
    const MatchGrid pooled = grid.maxPooled(factor);
    EXPECT_EQ(pooled.width(), (23 + factor - 1) / factor);
    EXPECT_EQ(pooled.height(), (17 + factor - 1) / factor);
    EXPECT_DOUBLE_EQ(pooled.resolution(), factor * grid.resolution());
    EXPECT_EQ(pooled.origin(), grid.origin());
    for (int y = 0; y < pooled.height(); ++y) {
      for (int x = 0; x < pooled.width(); ++x) {
        float best = -1.0F;  // cells past the far edges read unknown
        for (int j = 0; j < factor; ++j) {
          for (int i = 0; i < factor; ++i) {
            const int gx = factor * x + i, gy = factor * y + j;
            best = std::max(best, grid.contains(gx, gy) ? grid.at(gx, gy) : grid.unknown());
          }
        }
        ASSERT_EQ(pooled.at(x, y), best) << "factor " << factor << " cell " << x << ", " << y;
      }
    }
  }
}

TEST(PrecomputationGrid, EqualsBruteForceMaxima) {
  std::mt19937 rng(7);
  const MatchGrid grid = randomGrid(rng, 23, 17);
  for (int h = 0; h < 5; ++h) {
    const PrecomputationGrid level(grid, h);
    const int w = 1 << h;
    for (int y = -w - 3; y < grid.height() + 3; ++y) {
      for (int x = -w - 3; x < grid.width() + 3; ++x) {
        std::uint8_t expected = 0;
        for (int j = 0; j < w; ++j)
          for (int i = 0; i < w; ++i)
            expected = std::max(expected, quantizeProbability(grid.at(x + i, y + j)));
        ASSERT_EQ(level.at(x, y), expected) << "level " << h << " at " << x << "," << y;
      }
    }
  }
}

// The stack builds each level from the one before (doubling); every level must equal the one
// built from the grid directly, which the test above checks against brute-force maxima.
TEST(PrecomputationGrid, StackLevelsByDoublingEqualDirectLevels) {
  std::mt19937 rng(11);
  for (const auto& [w, h] : {std::pair{23, 17}, std::pair{1, 40}, std::pair{64, 3}}) {
    const MatchGrid grid = randomGrid(rng, w, h);
    const PrecomputationGridStack stack(grid, 7);
    for (int level = 0; level < stack.depth(); ++level) {
      const PrecomputationGrid direct(grid, level);
      const int side = 1 << level;
      for (int y = -side - 3; y < grid.height() + 3; ++y) {
        for (int x = -side - 3; x < grid.width() + 3; ++x) {
          ASSERT_EQ(stack.level(level).at(x, y), direct.at(x, y))
              << w << "x" << h << " level " << level << " at " << x << "," << y;
        }
      }
    }
  }
}

// A scan of the grid's strongest cells seen from a known pose, so that the best match is distinct.
PointCloud scanOf(const MatchGrid& grid, const core::Pose2& pose, std::mt19937& rng, int n) {
  std::uniform_int_distribution<int> cx(0, grid.width() - 1);
  std::uniform_int_distribution<int> cy(0, grid.height() - 1);
  PointCloud points;
  const Eigen::Matrix2d Rt = core::rotation(pose.z()).transpose();
  while (static_cast<int>(points.size()) < n) {
    const int x = cx(rng);
    const int y = cy(rng);
    if (grid.at(x, y) < 0.5F) continue;
    const Eigen::Vector2d world =
        grid.origin() + grid.resolution() * Eigen::Vector2d(x + 0.5, y + 0.5);
    points.push_back(Rt * (world - pose.head<2>()));
  }
  return points;
}

class BranchAndBoundVersusExhaustive : public ::testing::TestWithParam<unsigned> {};

TEST_P(BranchAndBoundVersusExhaustive, SameBestPose) {
  std::mt19937 rng(GetParam());
  const MatchGrid grid = randomGrid(rng, 40, 36);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  const core::Pose2 truth(1.5 + jitter(rng), 1.2 + jitter(rng), jitter(rng));
  const PointCloud points = scanOf(grid, truth, rng, 30);
  const core::Pose2 initial = truth + core::Pose2(jitter(rng), jitter(rng), 0.3 * jitter(rng));
  const SearchWindow window{0.8, 0.2};
  for (int depth : {1, 3, 5}) {
    const FastCorrelativeScanMatcher matcher(grid, depth);
    for (double min_score : {0.0, 0.5, 0.99}) {
      const auto exhaustive = matcher.matchExhaustive(initial, points, window, min_score);
      const auto fast = matcher.match(initial, points, window, min_score);
      ASSERT_EQ(exhaustive.has_value(), fast.has_value()) << "depth " << depth;
      if (!fast) continue;
      EXPECT_DOUBLE_EQ(fast->score, exhaustive->score) << "depth " << depth;
      EXPECT_TRUE(fast->pose.isApprox(exhaustive->pose, 1e-12))
          << "depth " << depth << ": " << fast->pose.transpose() << " vs "
          << exhaustive->pose.transpose();
      // The best pose elsewhere: the same with the best's place left out, and outside it.
      const Exclusion place{fast->pose, 0.25, 0.1};
      const auto slow_beyond = matcher.matchExhaustive(initial, points, window, min_score, place);
      const auto fast_beyond = matcher.match(initial, points, window, min_score, place);
      ASSERT_EQ(slow_beyond.has_value(), fast_beyond.has_value()) << "depth " << depth;
      if (!fast_beyond) continue;
      EXPECT_DOUBLE_EQ(fast_beyond->score, slow_beyond->score) << "depth " << depth;
      EXPECT_TRUE(fast_beyond->pose.isApprox(slow_beyond->pose, 1e-12)) << "depth " << depth;
      EXPECT_LE(fast_beyond->score, fast->score);
      EXPECT_TRUE((fast_beyond->pose.head<2>() - fast->pose.head<2>()).norm() > 0.25 - 1e-9 ||
                  std::abs(core::normalizeAngle(fast_beyond->pose.z() - fast->pose.z())) >
                      0.1 - 1e-9)
          << fast_beyond->pose.transpose();
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, BranchAndBoundVersusExhaustive,
                         ::testing::Values(1U, 2U, 3U, 4U, 5U, 6U, 7U, 8U));

TEST(BranchAndBound, FullSubmapSearchFindsAPoseFarOutsideAnyWindow) {
  std::mt19937 rng(12);
  const MatchGrid grid = randomGrid(rng, 60, 50);
  const core::Pose2 truth(2.0, 1.5, 2.5);
  const PointCloud points = scanOf(grid, truth, rng, 50);
  const FastCorrelativeScanMatcher matcher(grid, 5);
  const auto found = matcher.matchFullSubmap(points, 0.5);
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(found->pose.head<2>().isApprox(truth.head<2>(), 0.06)) << found->pose.transpose();
  EXPECT_NEAR(core::normalizeAngle(found->pose.z() - truth.z()), 0.0, 0.05);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
