#pragma once
// Maximum clique of a small undirected graph: branch and bound with greedy-colouring bounds
// (Tomita and Seki's MCQ, "An efficient branch-and-bound algorithm for finding a maximum
// clique", 2003), on bitset rows. RRR uses it to split a time cluster into sets of pairwise
// consistent loop links, as PCM does (Mangelson et al., ICRA 2018).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rrr_graphslam::core {

/// Symmetric adjacency of vertices 0..n-1 (no self-loops), one bit per pair.
class AdjacencyMatrix {
 public:
  explicit AdjacencyMatrix(int n);
  int size() const { return n_; }
  void connect(int a, int b);
  bool connected(int a, int b) const {
    const auto bit = static_cast<std::size_t>(b);
    return (bits_[static_cast<std::size_t>(a) * words_ + bit / 64] >> (bit % 64)) & 1U;
  }
  /// Vertex a's neighbours as words() 64-bit words (bit b of word b / 64).
  const std::uint64_t* row(int a) const {
    return bits_.data() + static_cast<std::size_t>(a) * words_;
  }
  std::size_t words() const { return words_; }

 private:
  int n_;
  std::size_t words_;
  std::vector<std::uint64_t> bits_;
};

/// A maximum clique (sorted vertex ids) among the vertices of `among` (all if empty).
/// Exact unless `max_branches` branch steps do not suffice; then the largest clique found by
/// then, which is still a clique (the first descent is greedy, so never a poor one).
std::vector<int> maximumClique(const AdjacencyMatrix& graph, const std::vector<int>& among = {},
                               long max_branches = 200000);

/// A large clique (sorted vertex ids) for graphs too large for the exact search: the greedy
/// heuristic of Pattabiraman et al. ("Fast algorithms for the maximum clique problem on massive
/// graphs with applications to overlapping community detection", Internet Mathematics 2015), as
/// PCM's implementation offers it. From each vertex in decreasing order of degree, the clique
/// grows by the vertex of highest degree among the common neighbours so far; vertices whose degree
/// cannot reach the best clique found are skipped. O(n (n + c n / 64)) for a clique of c.
/// Always a clique, at most as large as maximumClique's.
std::vector<int> heuristicMaximumClique(const AdjacencyMatrix& graph);

}  // namespace rrr_graphslam::core
