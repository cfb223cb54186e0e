// Candidate clustering: the relation, order independence, and the derived gap.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "rrr_graphslam/rrr/clustering.h"

namespace rrr_graphslam::rrr {
namespace {

std::set<std::set<std::pair<int, int>>> asSets(const std::vector<CandidateEnds>& ends,
                                               const std::vector<std::vector<int>>& clusters) {
  std::set<std::set<std::pair<int, int>>> out;
  for (const auto& c : clusters) {
    std::set<std::pair<int, int>> members;
    for (int k : c) members.insert(ends[static_cast<std::size_t>(k)]);
    out.insert(members);
  }
  return out;
}

TEST(Clustering, BothEndsMustBeWithinTheGap) {
  const std::vector<CandidateEnds> ends = {{100, 10},  {103, 12}, {106, 14},  // a revisit
                                           {104, 60},               // near in one end only
                                           {500, 400}, {10, 100}};  // apart; reversed pair
  const auto clusters = clusterCandidates(ends, 3);
  ASSERT_EQ(clusters.size(), 3u);
  EXPECT_EQ(clusters[0], (std::vector<int>{0, 1, 2, 5}));  // (10,100) is (100,10) reversed
  EXPECT_EQ(clusters[1], (std::vector<int>{3}));
  EXPECT_EQ(clusters[2], (std::vector<int>{4}));
}

TEST(Clustering, NeighbouringIdsOfTwoSessionsAreNotNeighbours) {
  // Nodes 0..99 are one session, 100..199 the next: 98 and 101 are consecutive-ish ids of two
  // unrelated runs.
  std::vector<int> session_of(200, 0);
  std::fill(session_of.begin() + 100, session_of.end(), 1);
  const std::vector<CandidateEnds> ends = {{10, 98}, {12, 101}, {14, 103}};
  EXPECT_EQ(clusterCandidates(ends, 3).size(), 1u);  // without sessions: one revisit
  const auto clusters = clusterCandidates(ends, 3, session_of);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0], (std::vector<int>{0}));
  EXPECT_EQ(clusters[1], (std::vector<int>{1, 2}));
}

TEST(Clustering, DoesNotDependOnOrder) {
  std::mt19937 rng(2);
  std::uniform_int_distribution<int> node(0, 400);
  std::vector<CandidateEnds> ends;
  for (int k = 0; k < 300; ++k) ends.emplace_back(node(rng), node(rng));
  const auto reference = asSets(ends, clusterCandidates(ends, 5));
  for (int trial = 0; trial < 5; ++trial) {
    std::shuffle(ends.begin(), ends.end(), rng);
    EXPECT_EQ(asSets(ends, clusterCandidates(ends, 5)), reference);
  }
}

TEST(Clustering, DerivedGapFollowsCandidateSpacing) {
  std::vector<CandidateEnds> every_node, every_fifth;
  for (int k = 0; k < 100; ++k) {
    every_node.emplace_back(1000 + k, k);
    every_fifth.emplace_back(1000 + 5 * k, 5 * k);
  }
  EXPECT_EQ(deriveClusterGap(every_node), 3);    // 2.5 x 1, rounded
  EXPECT_EQ(deriveClusterGap(every_fifth), 13);  // 2.5 x 5
  EXPECT_EQ(deriveClusterGap({}), 2);
  EXPECT_EQ(deriveClusterGap({{0, 100}, {5000, 9000}}), 50);  // nothing close: the cap
}

}  // namespace
}  // namespace rrr_graphslam::rrr
