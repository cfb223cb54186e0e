// OdometryChain's O(1) compounding against the step-by-step first-order recursion.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "rrr_graphslam/rrr/odometry_chain.h"

namespace rrr_graphslam::rrr {
namespace {

using core::Pose2;

Eigen::Matrix3d randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.5, 2.0);
  Eigen::Matrix3d A = Eigen::Matrix3d::Random() * 0.3;
  Eigen::Matrix3d info = A * A.transpose();
  info.diagonal() += Eigen::Vector3d(u(rng) * 100.0, u(rng) * 100.0, u(rng) * 400.0);
  return info;
}

std::vector<OdometryChain::Link> randomChain(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> step(-1.0, 1.0);
  std::vector<OdometryChain::Link> links;
  for (int i = 0; i + 1 < n; ++i) {
    links.push_back({i, i + 1, Pose2(1.0 + 0.3 * step(rng), 0.3 * step(rng), 0.6 * step(rng)),
                     randomInformation(rng)});
  }
  return links;
}

TEST(OdometryChain, CompoundedCovarianceMatchesRecursion) {
  std::mt19937 rng(11);
  const int n = 60;
  const auto links = randomChain(n, rng);
  const OdometryChain chain(n, links);
  for (int a : {0, 7, 30}) {
    Pose2 z = Pose2::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int b = a + 1; b < n; ++b) {
      // Right-noise recursion: appending step s moves the old noise through Ad(s^-1).
      const auto& s = links[static_cast<std::size_t>(b - 1)];
      const Eigen::Matrix3d Ad = core::adjoint(core::inverse(s.measurement));
      cov = Ad * cov * Ad.transpose() + s.information.inverse();
      z = core::compose(z, s.measurement);
      Pose2 d = chain.relativePose(a, b) - z;
      d.z() = core::normalizeAngle(d.z());
      EXPECT_LT(d.norm(), 1e-9) << a << "->" << b;
      EXPECT_LT((chain.relativeCovariance(a, b) - cov).norm(), 1e-8 * (1.0 + cov.norm()))
          << a << "->" << b;
    }
  }
}

TEST(OdometryChain, ReversedAndDuplicateLinks) {
  std::mt19937 rng(3);
  auto links = randomChain(5, rng);
  const OdometryChain forward(5, links);
  // The same step written backwards: inverse measurement, information moved through Ad(z).
  auto reversed = links;
  auto& l = reversed[2];
  const Eigen::Matrix3d Ad = core::adjoint(l.measurement);
  l = {3, 2, core::inverse(l.measurement), Ad.transpose().inverse() * l.information * Ad.inverse()};
  // Ad(z)^-T Omega Ad(z)^-1 is the information of z^-1; reading it back must give the original.
  const OdometryChain backward(5, reversed);
  EXPECT_LT((backward.relativePose(0, 4) - forward.relativePose(0, 4)).norm(), 1e-9);
  EXPECT_LT((backward.relativeCovariance(0, 4) - forward.relativeCovariance(0, 4)).norm(), 1e-9);

  // Two identical measurements of a step halve its covariance.
  auto doubled = links;
  doubled.push_back(links[1]);
  const OdometryChain fused(5, doubled);
  EXPECT_LT((fused.relativeCovariance(1, 2) - 0.5 * forward.relativeCovariance(1, 2)).norm(),
            1e-12);
}

TEST(OdometryChain, GrowingNodeByNodeEqualsBuildingAtOnce) {
  std::mt19937 rng(9);
  auto links = randomChain(12, rng);
  links.erase(links.begin() + 5);  // a session break between 5 and 6
  links.push_back(links[2]);       // and a duplicate of step 2 -> 3
  const OdometryChain at_once(12, links);
  OdometryChain grown;
  for (int n = 0; n < 12; ++n) {
    grown.appendNode();
    for (const auto& l : links) {
      if (std::max(l.from, l.to) == n) grown.linkNewestNode(l);
    }
  }
  EXPECT_EQ(grown.numSessions(), at_once.numSessions());
  for (int a = 0; a < 12; ++a) {
    EXPECT_EQ(grown.session(a), at_once.session(a));
    for (int b = a + 1; b < 12; ++b) {
      if (!at_once.sameSession(a, b)) continue;
      EXPECT_LT((grown.relativePose(a, b) - at_once.relativePose(a, b)).norm(), 1e-12);
      EXPECT_LT((grown.relativeCovariance(a, b) - at_once.relativeCovariance(a, b)).norm(), 1e-12);
    }
  }
  EXPECT_THROW(grown.linkNewestNode({3, 4, Pose2::Zero(), Eigen::Matrix3d::Identity()}),
               std::invalid_argument);
}

TEST(OdometryChain, SessionsAndErrors) {
  std::mt19937 rng(5);
  auto links = randomChain(8, rng);
  links.erase(links.begin() + 3);  // no link 3 -> 4: two sessions
  const OdometryChain chain(8, links);
  EXPECT_EQ(chain.numSessions(), 2);
  EXPECT_TRUE(chain.sameSession(0, 3));
  EXPECT_FALSE(chain.sameSession(3, 4));
  EXPECT_EQ(chain.sessionStart(6), 4);
  EXPECT_EQ(chain.chainPose(4), Pose2::Zero());
  links.push_back({1, 5, Pose2::Zero(), Eigen::Matrix3d::Identity()});
  EXPECT_THROW(OdometryChain(8, links), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
