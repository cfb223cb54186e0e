// Maximum clique: branch and bound against brute force over every vertex subset.

#include <gtest/gtest.h>

#include <random>

#include "rrr_graphslam/core/max_clique.h"

namespace rrr_graphslam::core {
namespace {

bool isClique(const AdjacencyMatrix& g, const std::vector<int>& vertices) {
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (std::size_t j = i + 1; j < vertices.size(); ++j)
      if (!g.connected(vertices[i], vertices[j])) return false;
  return true;
}

// The slow, obvious version: every subset of `among`.
std::size_t bruteForceMaximum(const AdjacencyMatrix& g, const std::vector<int>& among) {
  std::size_t best = 0;
  for (unsigned mask = 1; mask < (1U << among.size()); ++mask) {
    std::vector<int> subset;
    for (std::size_t i = 0; i < among.size(); ++i)
      if (mask & (1U << i)) subset.push_back(among[i]);
    if (subset.size() > best && isClique(g, subset)) best = subset.size();
  }
  return best;
}

TEST(MaxClique, AgreesWithBruteForce) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 14;
    const double density = std::uniform_real_distribution<double>(0.1, 0.95)(rng);
    AdjacencyMatrix g(n);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b)
        if (std::bernoulli_distribution(density)(rng)) g.connect(a, b);
    std::vector<int> all, some;
    for (int v = 0; v < n; ++v) {
      all.push_back(v);
      if (v % 3 != 1) some.push_back(v);
    }
    const std::vector<int> clique = maximumClique(g);
    EXPECT_TRUE(isClique(g, clique));
    EXPECT_TRUE(std::is_sorted(clique.begin(), clique.end()));
    EXPECT_EQ(clique.size(), bruteForceMaximum(g, all)) << "trial " << trial;
    const std::vector<int> within = maximumClique(g, some);
    EXPECT_TRUE(isClique(g, within));
    for (int v : within) EXPECT_NE(v % 3, 1);
    EXPECT_EQ(within.size(), bruteForceMaximum(g, some)) << "trial " << trial;
  }
}

TEST(MaxClique, DisjointCliquesAndBudget) {
  // A 5-clique and a 7-clique joined by one edge: the 7 wins, whatever the vertex order.
  AdjacencyMatrix g(12);
  const std::vector<int> five{0, 2, 4, 6, 8}, seven{1, 3, 5, 7, 9, 10, 11};
  for (const auto* c : {&five, &seven})
    for (std::size_t i = 0; i < c->size(); ++i)
      for (std::size_t j = i + 1; j < c->size(); ++j) g.connect((*c)[i], (*c)[j]);
  g.connect(0, 1);
  EXPECT_EQ(maximumClique(g), seven);
  // Out of budget at once: still a clique, never empty.
  const std::vector<int> early = maximumClique(g, {}, 0);
  EXPECT_FALSE(early.empty());
  EXPECT_TRUE(isClique(g, early));
  EXPECT_TRUE(maximumClique(AdjacencyMatrix(0)).empty());
  EXPECT_THROW(g.connect(3, 3), std::invalid_argument);
  EXPECT_THROW(g.connect(0, 12), std::invalid_argument);
}

// The heuristic (PCM's option for large consistency graphs): always a clique, never larger than
// the exact one; it finds a planted clique that dominates the graph, as PCM's inliers do.
TEST(MaxClique, HeuristicIsACliqueAndFindsAPlantedOne) {
  std::mt19937 rng(7);
  std::bernoulli_distribution half(0.5);
  for (int trial = 0; trial < 50; ++trial) {
    AdjacencyMatrix g(14);
    for (int a = 0; a < 14; ++a)
      for (int b = a + 1; b < 14; ++b)
        if (half(rng)) g.connect(a, b);
    const std::vector<int> found = heuristicMaximumClique(g);
    EXPECT_FALSE(found.empty());
    EXPECT_TRUE(isClique(g, found)) << "trial " << trial;
    EXPECT_TRUE(std::is_sorted(found.begin(), found.end()));
    EXPECT_LE(found.size(), maximumClique(g).size()) << "trial " << trial;
  }
  // 600 vertices, 30% background density, a clique of 200 planted on every third vertex.
  AdjacencyMatrix g(600);
  std::bernoulli_distribution sparse(0.3);
  std::vector<int> planted;
  for (int v = 0; v < 600; v += 3) planted.push_back(v);
  for (int a = 0; a < 600; ++a)
    for (int b = a + 1; b < 600; ++b)
      if ((a % 3 == 0 && b % 3 == 0) || sparse(rng)) g.connect(a, b);
  EXPECT_EQ(heuristicMaximumClique(g), planted);
  EXPECT_TRUE(heuristicMaximumClique(AdjacencyMatrix(0)).empty());
}

}  // namespace
}  // namespace rrr_graphslam::core
