// Placing a session in the map (session_placement.h, RrrParams::placement_min_spread_m): links
// that agree on where a session lies close their cycle, an aliased one does not; a session is tied
// by a group of agreeing clusters seen far enough apart, never by a lone cluster that arrived
// first.

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "rrr_graphslam/rrr/online_rrr.h"
#include "rrr_graphslam/rrr/session_placement.h"

namespace rrr_graphslam::rrr {
namespace {

using NodeId = core::PoseGraph::NodeId;

// The map: 200 nodes 0.5 m apart along a corridor (x). The new session drives the same corridor
// from x = 10 m, in its own odometry frame.
constexpr int kMapNodes = 200;
constexpr NodeId kSessionStart = 1000;
const Eigen::Matrix3d kOdometryInformation = Eigen::Vector3d(1e4, 1e4, 1e5).asDiagonal();
const Eigen::Matrix3d kLoopInformation = Eigen::Vector3d(400.0, 400.0, 2500.0).asDiagonal();

core::Pose2 mapTruth(int k) { return {0.5 * k, 0.0, 0.0}; }
core::Pose2 sessionTruth(int k) { return {10.0 + 0.5 * k, 0.1, 0.0}; }
const core::Pose2 kSessionFrame(-40.0, 25.0, 1.0);  // where its odometry frame lies in the map

void addMap(OnlineRrr& online) {
  online.startSession(0, mapTruth(0));
  for (int k = 1; k < kMapNodes; ++k) {
    online.addOdometry(k - 1, k, core::between(mapTruth(k - 1), mapTruth(k)), kOdometryInformation);
  }
}

void addSessionNode(OnlineRrr& online, int k) {
  const NodeId id = kSessionStart + static_cast<NodeId>(k);
  if (k == 0) {
    online.startSession(id, core::compose(core::inverse(kSessionFrame), sessionTruth(0)));
    return;
  }
  online.addOdometry(id - 1, id, core::between(sessionTruth(k - 1), sessionTruth(k)),
                     kOdometryInformation);
}

// Session node k seen from map node m; `alias` shifts the map end (a corridor like another).
void addLoop(OnlineRrr& online, int m, int k, int alias = 0) {
  online.addCandidate(static_cast<NodeId>(m + alias), kSessionStart + static_cast<NodeId>(k),
                      core::between(mapTruth(m), sessionTruth(k)), kLoopInformation);
}

TEST(SessionPlacement, AgreeingLinksCloseTheirCycleAnAliasedOneDoesNot) {
  OnlineRrr online;
  addMap(online);
  for (int k = 0; k < 60; ++k) addSessionNode(online, k);
  addLoop(online, 25, 5);       // candidate 0: right
  addLoop(online, 75, 55);      // candidate 1: right, 25 m further along
  addLoop(online, 45, 25, 30);  // candidate 2: the same view put 15 m off
  const VerificationGraph& graph = online.verificationGraph();
  const std::vector<core::Pose2> poses = online.mapPoses();
  auto joining = [&](int candidate) {
    const LoopCandidate& c = graph.candidate(candidate);
    return JoiningLink{candidate, c.from, c.to};
  };
  EXPECT_LT(placementCycleChi2(graph, poses, joining(0), joining(1)), 1.0);
  EXPECT_GT(placementCycleChi2(graph, poses, joining(0), joining(2)), 1e3);
  EXPECT_GT(placementCycleChi2(graph, poses, joining(2), joining(1)), 1e3);

  const PlacementGroup group =
      largestAgreeingGroup(graph, poses, {joining(0), joining(2), joining(1)}, 0.95);
  EXPECT_EQ(group.members, (std::vector<int>{0, 2}));
  EXPECT_NEAR(group.spread_m, 25.0, 1e-6);
}

TEST(SessionPlacement, TheCycleChi2OfNoisyTrueLinksFollowsItsDistribution) {
  // Odometry and links drawn with the noise their information matrices state, one link stored
  // from the map to the session and one the other way: the statistic is chi2(3), so about 95% of
  // the draws fall below chi2(0.95, 3) = 7.815 and half below its median 2.366.
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto noisy = [&](const core::Pose2& z, const Eigen::Matrix3d& information) {
    const Eigen::Matrix3d l = information.inverse().llt().matrixL();
    const Eigen::Vector3d n = l * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    return core::compose(z, n);
  };
  const int trials = 1000;
  int below_95 = 0, below_median = 0;
  for (int t = 0; t < trials; ++t) {
    OnlineRrr online;  // placement_min_spread_m 0: nothing waits, nothing is moved
    addMap(online);
    online.startSession(kSessionStart, core::Pose2(3.0, -2.0, 0.4));
    for (int k = 1; k <= 60; ++k) {
      online.addOdometry(
          kSessionStart + static_cast<NodeId>(k - 1), kSessionStart + static_cast<NodeId>(k),
          noisy(core::between(sessionTruth(k - 1), sessionTruth(k)), kOdometryInformation),
          kOdometryInformation);
    }
    online.addCandidate(25, kSessionStart + 5,
                        noisy(core::between(mapTruth(25), sessionTruth(5)), kLoopInformation),
                        kLoopInformation);
    online.addCandidate(kSessionStart + 55, 75,
                        noisy(core::between(sessionTruth(55), mapTruth(75)), kLoopInformation),
                        kLoopInformation);
    const VerificationGraph& graph = online.verificationGraph();
    const JoiningLink a{0, graph.candidate(0).from, graph.candidate(0).to};
    const JoiningLink b{1, graph.candidate(1).to, graph.candidate(1).from};
    const double chi2 = placementCycleChi2(graph, online.mapPoses(), a, b);
    below_95 += chi2 < 7.815 ? 1 : 0;
    below_median += chi2 < 2.366 ? 1 : 0;
  }
  EXPECT_NEAR(below_95 / static_cast<double>(trials), 0.95, 0.025);
  EXPECT_NEAR(below_median / static_cast<double>(trials), 0.5, 0.05);
}

// The robot enters the corridor; an aliased match comes first, true ones later, 15 m apart.
OnlineRrr& drive(OnlineRrr& online, int until, std::vector<int>* checkpoints = nullptr) {
  for (int k = 0; k <= until; ++k) {
    addSessionNode(online, k);
    if (k == 5) {
      addLoop(online, 25, 5, 30);
      addLoop(online, 26, 5, 30);
    }
    if (k == 30) {
      addLoop(online, 50, 30);
      addLoop(online, 51, 30);
    }
    if (k == 60) {
      addLoop(online, 80, 60);
      addLoop(online, 81, 60);
    }
    if (checkpoints != nullptr) checkpoints->push_back(online.numCandidates());
  }
  return online;
}

OnlineRrrParams withSpread(double spread_m) {
  OnlineRrrParams params;
  params.rrr.placement_min_spread_m = spread_m;
  return params;
}

// Two readings of the same corridor, matched at the same session nodes: the true one and an
// aliased one (every match 15 m off, agreeing with one another), two clusters each 15 m apart by
// session node 45; then the true reading alone matches twice more.
struct Match {
  int k;      // session node
  int alias;  // map nodes the match is off by
};
const std::vector<Match> kTwoReadings{{5, 0}, {5, 30}, {35, 0}, {35, 30}, {80, 0}, {110, 0}};

OnlineRrr& driveTwoReadings(OnlineRrr& online, int until) {
  for (int k = 0; k <= until; ++k) {
    addSessionNode(online, k);
    for (const Match& match : kTwoReadings) {
      if (match.k == k) addLoop(online, 20 + k, k, match.alias);
    }
  }
  return online;
}

OnlineRrrParams withSpreadAndRatio(double spread_m, double ratio) {
  OnlineRrrParams params = withSpread(spread_m);
  params.rrr.placement_min_ratio = ratio;
  return params;
}

TEST(SessionPlacement, TwoReadingsAlikeWaitUntilOneHasTwiceTheClusters) {
  // Candidates 0, 2, 4, 5: the true reading; 1, 3: the aliased one.
  OnlineRrr even(withSpreadAndRatio(10.0, 2.0));
  addMap(even);
  driveTwoReadings(even, 70);  // two clusters each, both 15 m apart: neither places the session
  ASSERT_EQ(even.numCandidates(), 4);
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(even.verdict(c), Verdict::kPending) << c << ": " << even.reason(c);
    EXPECT_NE(even.reason(c).find("a rival group of 2 clusters"), std::string::npos)
        << even.reason(c);
  }
  OnlineRrr three(withSpreadAndRatio(10.0, 2.0));
  addMap(three);
  driveTwoReadings(three, 100);  // three clusters to two: still not twice as many
  ASSERT_EQ(three.numCandidates(), 5);
  for (int c = 0; c < 5; ++c) {
    EXPECT_EQ(three.verdict(c), Verdict::kPending) << c << ": " << three.reason(c);
  }
  // A run that ends here leaves the session untied: the batch decision's placement holds it too.
  three.finish();
  for (int c = 0; c < 5; ++c) {
    EXPECT_EQ(three.verdict(c), Verdict::kRejected) << c << ": " << three.reason(c);
    EXPECT_NE(three.reason(c).find("placement:"), std::string::npos) << three.reason(c);
  }

  OnlineRrr ahead(withSpreadAndRatio(10.0, 2.0));
  addMap(ahead);
  driveTwoReadings(ahead, 130);  // four clusters to two: the true reading ties the session
  ASSERT_EQ(ahead.numCandidates(), 6);
  for (int c : {1, 3}) EXPECT_EQ(ahead.verdict(c), Verdict::kRejected) << ahead.reason(c);
  for (int c : {0, 2, 4, 5}) {
    EXPECT_EQ(ahead.verdict(c), Verdict::kAccepted) << c << ": " << ahead.reason(c);
  }
  ahead.finish();
  for (int c : {1, 3}) EXPECT_EQ(ahead.verdict(c), Verdict::kRejected);
  for (int c : {0, 2, 4, 5}) EXPECT_EQ(ahead.verdict(c), Verdict::kAccepted);
}

// The stretch of a set of links whose places along the session are `at`.
std::function<double(const std::vector<int>&)> stretchAlong(std::vector<double> at) {
  return [at = std::move(at)](const std::vector<int>& members) {
    double lo = 1e9, hi = -1e9;
    for (int k : members) {
      lo = std::min(lo, at[static_cast<std::size_t>(k)]);
      hi = std::max(hi, at[static_cast<std::size_t>(k)]);
    }
    return hi - lo;
  };
}

TEST(SessionPlacement, TheRivalSeenOverALongerStretchPlacesTheSession) {
  PlacementGroup group;
  group.members = {0, 1, 2};
  group.rival = {3, 4};
  PlacementGroup wider = group;
  preferWiderReading(wider, stretchAlong({0.0, 4.0, 8.0, 0.0, 30.0}));
  EXPECT_EQ(wider.members, (std::vector<int>{3, 4}));
  EXPECT_EQ(wider.rival, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(wider.spread_m, 30.0);
  // A rival of one cluster, or of fewer than half the group's, never places the session.
  PlacementGroup lone = group;
  lone.rival = {4};
  preferWiderReading(lone, stretchAlong({0.0, 4.0, 8.0, 0.0, 30.0}));
  EXPECT_EQ(lone.members, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(lone.spread_m, 8.0);
  PlacementGroup outnumbered = group;
  outnumbered.members = {0, 1, 2, 5, 6};
  preferWiderReading(outnumbered, stretchAlong({0.0, 4.0, 8.0, 0.0, 30.0, 5.0, 6.0}));
  EXPECT_EQ(outnumbered.members, (std::vector<int>{0, 1, 2, 5, 6}));
  // A stretch not longer than the group's: the larger group stays.
  PlacementGroup even = group;
  preferWiderReading(even, stretchAlong({0.0, 4.0, 8.0, 1.0, 9.0}));
  EXPECT_EQ(even.members, (std::vector<int>{0, 1, 2}));
}

// An aliased reading matched three times over 11 m of the session ties it first; the true one
// matches (two links each time) at the session's start and again 37.5 m on, where the likeness
// has ended.
OnlineRrr& driveAliasFirst(OnlineRrr& online, int until) {
  const std::vector<Match> matches{{5, 0}, {6, 30}, {17, 30}, {28, 30}, {80, 0}};
  for (int k = 0; k <= until; ++k) {
    addSessionNode(online, k);
    for (const Match& match : matches) {
      if (match.k != k) continue;
      addLoop(online, 20 + k, k, match.alias);
      if (match.alias == 0) addLoop(online, 21 + k, k);
    }
  }
  return online;
}

TEST(SessionPlacement, TheReadingSeenOverTheLongerStretchPlacesTheSession) {
  // Candidates 0, 1, 5, 6: the true reading (two clusters, 37.5 m apart); 2-4: the aliased one
  // (three clusters over 11 m). Ties need 20 m: only the true reading can tie the session, and
  // only when the larger group's rival is considered.
  const std::vector<int> right = {0, 1, 5, 6}, wrong = {2, 3, 4};
  for (const bool wider : {true, false}) {
    OnlineRrrParams params = withSpread(20.0);
    params.rrr.placement_wider_reading = wider;
    OnlineRrr online(params);
    addMap(online);
    driveAliasFirst(online, 100);
    ASSERT_EQ(online.numCandidates(), 7);
    for (int c : right) {
      EXPECT_EQ(online.verdict(c), wider ? Verdict::kAccepted : Verdict::kPending)
          << "wider " << wider << ", " << c << ": " << online.reason(c);
    }
    if (!wider) {
      EXPECT_NE(online.reason(0).find("has 3 of 5, seen 11.0 m apart"), std::string::npos)
          << online.reason(0);
    }
    online.finish();
    for (int c : right) {
      EXPECT_EQ(online.verdict(c), wider ? Verdict::kAccepted : Verdict::kRejected)
          << "wider " << wider << ", " << c << ": " << online.reason(c);
    }
    for (int c : wrong) {
      EXPECT_EQ(online.verdict(c), Verdict::kRejected)
          << "wider " << wider << ", " << c << ": " << online.reason(c);
    }
  }
}

TEST(SessionPlacement, ASessionTiedByAnAliasIsPlacedByTheWiderReadingFromScratch) {
  // Ties need 10 m: the aliased group spans 11 m first and ties the session online; the true
  // links that come later disagree with the tie. The decision from scratch places the session by
  // the reading seen over the longer stretch.
  OnlineRrr online(withSpread(10.0));
  addMap(online);
  driveAliasFirst(online, 100);
  ASSERT_EQ(online.numCandidates(), 7);
  for (int c : {2, 3, 4}) {
    EXPECT_EQ(online.verdict(c), Verdict::kAccepted) << c << ": " << online.reason(c);
  }
  for (int c : {5, 6}) EXPECT_NE(online.verdict(c), Verdict::kAccepted) << online.reason(c);
  online.finish();
  for (int c : {0, 1, 5, 6}) {
    EXPECT_EQ(online.verdict(c), Verdict::kAccepted) << c << ": " << online.reason(c);
  }
  for (int c : {2, 3, 4}) {
    EXPECT_EQ(online.verdict(c), Verdict::kRejected) << c << ": " << online.reason(c);
  }
}

TEST(SessionPlacement, ALoneAliasedClusterWaitsAndTheAgreeingGroupTiesTheSession) {
  OnlineRrr online(withSpread(10.0));
  addMap(online);
  drive(online, 25);  // the aliased cluster closed (gap 10): alone, it waits
  ASSERT_EQ(online.numCandidates(), 2);
  for (int c : {0, 1}) {
    EXPECT_EQ(online.verdict(c), Verdict::kPending);
    EXPECT_NE(online.reason(c).find("placement:"), std::string::npos) << online.reason(c);
  }
  OnlineRrr more(withSpread(10.0));
  addMap(more);
  drive(more, 50);  // the first true cluster closed: 0 m of spread in any group yet
  for (int c = 0; c < more.numCandidates(); ++c) EXPECT_EQ(more.verdict(c), Verdict::kPending);

  OnlineRrr all(withSpread(10.0));
  addMap(all);
  drive(all, 75);  // the second true one closed, 15 m from the first: the session is placed
  EXPECT_EQ(all.verdict(0), Verdict::kRejected) << all.reason(0);
  EXPECT_EQ(all.verdict(1), Verdict::kRejected);
  for (int c = 2; c < 6; ++c) EXPECT_EQ(all.verdict(c), Verdict::kAccepted) << all.reason(c);
  all.finish();
  EXPECT_EQ(all.verdict(0), Verdict::kRejected);
  for (int c = 2; c < 6; ++c) EXPECT_EQ(all.verdict(c), Verdict::kAccepted) << all.reason(c);
}

TEST(SessionPlacement, WithoutTheRuleTheFirstLoneClusterTiesTheSession) {
  // What the rule prevents: the paper's online decision accepts the aliased cluster (it closes no
  // cycle) and then rejects the true ones against it.
  OnlineRrr online(withSpread(0.0));
  addMap(online);
  drive(online, 25);
  EXPECT_EQ(online.verdict(0), Verdict::kAccepted);
  OnlineRrr later(withSpread(0.0));
  addMap(later);
  drive(later, 75);
  EXPECT_EQ(later.verdict(0), Verdict::kAccepted);
  EXPECT_EQ(later.verdict(2), Verdict::kRejected);
}

TEST(SessionPlacement, ASessionNeverPlacedEndsWithItsClustersRejectedSayingWhy) {
  OnlineRrr online(withSpread(10.0));
  addMap(online);
  drive(online, 40);  // the aliased cluster and one true one: no group spans 10 m
  online.finish();
  for (int c = 0; c < online.numCandidates(); ++c) {
    EXPECT_EQ(online.verdict(c), Verdict::kRejected);
    EXPECT_NE(online.reason(c).find("placement:"), std::string::npos) << online.reason(c);
  }
}

TEST(SessionPlacement, AnUntiedSessionsOwnLoopsAreDecidedAsAnyOther) {
  // Only the clusters joining the session to the map wait: its loops within itself close cycles
  // through its own odometry and are decided at once, tied or not, and kept at the end.
  OnlineRrr online(withSpread(10.0));
  addMap(online);
  for (int k = 0; k <= 60; ++k) {
    addSessionNode(online, k);
    if (k == 40) {
      for (int from : {2, 3}) {
        online.addCandidate(kSessionStart + static_cast<NodeId>(from), kSessionStart + 40,
                            core::between(sessionTruth(from), sessionTruth(40)), kLoopInformation);
      }
    }
  }
  ASSERT_EQ(online.numCandidates(), 2);
  EXPECT_EQ(online.verdict(0), Verdict::kAccepted) << online.reason(0);
  EXPECT_EQ(online.verdict(1), Verdict::kAccepted);
  online.finish();
  EXPECT_EQ(online.verdict(0), Verdict::kAccepted) << online.reason(0);
  EXPECT_EQ(online.verdict(1), Verdict::kAccepted);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
