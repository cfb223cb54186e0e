// Direct scan-to-scan alignment: two ray-cast scans of the synthetic room are aligned back to
// their true relative pose from a start metres and degrees off, and the overlap fraction equals a
// brute-force count over every pair of points.

#include <gtest/gtest.h>

#include <random>

#include "rrr_graphslam/frontend/scan_alignment.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

PointCloud pointsAt(const core::Pose2& pose) {
  return matchingPoints(testing::castScan(testing::room(), pose), RangeScanParams{});
}

double bruteForceOverlap(const PointCloud& reference, const PointCloud& query,
                         const core::Pose2& pose, double distance_m) {
  int within = 0;
  for (const auto& p : query) {
    const Eigen::Vector2d q = pose.head<2>() + core::rotation(pose.z()) * p;
    bool near = false;
    for (const auto& r : reference) near = near || (q - r).norm() <= distance_m;
    within += near;
  }
  return static_cast<double>(within) / static_cast<double>(query.size());
}

TEST(ScanAlignment, RecoversTheRelativePoseFromAStartMetresOff) {
  const core::Pose2 a(3.0, 2.0, 0.3), b(5.5, 3.0, -0.4);
  const core::Pose2 truth = core::between(a, b);
  const PointCloud pa = pointsAt(a), pb = pointsAt(b);
  for (const core::Pose2& off :
       {core::Pose2(1.5, -0.8, 0.14), core::Pose2(-1.2, 1.1, -0.2), core::Pose2(0.0, 0.0, 0.0)}) {
    const auto aligned = alignScans(pa, pb, core::compose(truth, off), ScanAlignmentParams{});
    ASSERT_TRUE(aligned.has_value()) << off.transpose();
    EXPECT_NEAR(aligned->pose.x(), truth.x(), 0.03) << off.transpose();
    EXPECT_NEAR(aligned->pose.y(), truth.y(), 0.03) << off.transpose();
    EXPECT_NEAR(aligned->pose.z(), truth.z(), 0.01) << off.transpose();
    // The two poses see different parts of the room (the inner wall hides some from each):
    // about half the points overlap even at the true pose.
    EXPECT_GE(overlapFraction(pa, pb, aligned->pose, 0.1), overlapFraction(pa, pb, truth, 0.1));
  }
}

TEST(ScanAlignment, FindsNothingOutsideItsWindowOrWithoutPoints) {
  const core::Pose2 a(3.0, 2.0, 0.3), b(5.5, 3.0, -0.4);
  const PointCloud pa = pointsAt(a), pb = pointsAt(b);
  ScanAlignmentParams params;
  params.min_score = 0.9;  // only the true pose scores this high
  const core::Pose2 truth = core::between(a, b);
  EXPECT_FALSE(alignScans(pa, pb, core::compose(truth, core::Pose2(0, 0, 0.6)), params));
  EXPECT_FALSE(alignScans({}, pb, truth, params));
  EXPECT_FALSE(alignScans(pa, {}, truth, params));
}

TEST(ScanAlignment, OverlapFractionEqualsABruteForceCount) {
  const core::Pose2 a(3.0, 2.0, 0.3), b(5.5, 3.0, -0.4);
  const PointCloud pa = pointsAt(a), pb = pointsAt(b);
  const core::Pose2 truth = core::between(a, b);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.2);
  for (int k = 0; k < 20; ++k) {
    const core::Pose2 pose = truth + core::Pose2(noise(rng), noise(rng), 0.2 * noise(rng));
    for (const double d : {0.05, 0.1, 0.3}) {
      EXPECT_DOUBLE_EQ(overlapFraction(pa, pb, pose, d), bruteForceOverlap(pa, pb, pose, d));
    }
  }
  const double at_truth = overlapFraction(pa, pb, truth, 0.1);
  EXPECT_GT(at_truth, 0.4);
  EXPECT_LT(overlapFraction(pa, pb, core::compose(truth, core::Pose2(0.5, 0.0, 0.0)), 0.1),
            0.5 * at_truth);
  EXPECT_EQ(overlapFraction(pa, {}, truth, 0.1), 0.0);
  EXPECT_EQ(overlapFraction({}, pb, truth, 0.1), 0.0);
}

TEST(ScanAlignment, SurfacePointsFillGapsUpToTheLimitOnly) {
  const PointCloud points = {{0.0, 0.0}, {0.2, 0.0}, {0.2, 0.3}, {2.0, 0.3}};
  const PointCloud surface = surfacePoints(points, 0.5, 0.02);
  // 0.2 m and 0.3 m gaps filled every 2 cm (10 + 15 steps), the 1.8 m gap left open.
  ASSERT_EQ(surface.size(), 10U + 15U + 2U);
  for (std::size_t k = 0; k + 2 < surface.size(); ++k) {
    EXPECT_LE((surface[k + 1] - surface[k]).norm(), 0.02 + 1e-12) << k;
  }
  EXPECT_EQ(surface.back(), points.back());
  EXPECT_TRUE(surfacePoints({}, 0.5, 0.02).empty());
}

TEST(ScanAlignment, IcpAloneStaysAtTheNearestOptimum) {
  const core::Pose2 a(3.0, 2.0, 0.3), b(5.5, 3.0, -0.4);
  const core::Pose2 truth = core::between(a, b);
  const PointCloud pa = pointsAt(a), pb = pointsAt(b);
  const core::Pose2 near = refineScanIcp(
      pa, pb, core::compose(truth, core::Pose2(0.1, -0.05, 0.02)), ScanAlignmentParams{});
  EXPECT_LT((near - truth).head<2>().norm(), 0.03);
  EXPECT_LT(std::abs(near.z() - truth.z()), 0.01);
  // Unlike alignScans, it does not search: from 1.5 m off it does not reach the truth.
  const core::Pose2 far = refineScanIcp(pa, pb, core::compose(truth, core::Pose2(1.5, -0.8, 0.14)),
                                        ScanAlignmentParams{});
  EXPECT_GT((far - truth).head<2>().norm(), 0.3);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
