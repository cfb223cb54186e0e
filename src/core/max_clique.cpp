#include "rrr_graphslam/core/max_clique.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace rrr_graphslam::core {

AdjacencyMatrix::AdjacencyMatrix(int n)
    : n_(n), words_((static_cast<std::size_t>(std::max(n, 0)) + 63) / 64) {
  if (n < 0) throw std::invalid_argument("AdjacencyMatrix: negative size " + std::to_string(n));
  bits_.assign(words_ * static_cast<std::size_t>(n), 0);
}

void AdjacencyMatrix::connect(int a, int b) {
  if (a < 0 || b < 0 || a >= n_ || b >= n_ || a == b) {
    throw std::invalid_argument("AdjacencyMatrix::connect: bad pair " + std::to_string(a) + ", " +
                                std::to_string(b) + " for " + std::to_string(n_) + " vertices");
  }
  auto set = [&](int r, int c) {
    bits_[static_cast<std::size_t>(r) * words_ + static_cast<std::size_t>(c) / 64] |=
        std::uint64_t{1} << (c % 64);
  };
  set(a, b);
  set(b, a);
}

namespace {

class MaxCliqueSearch {
 public:
  MaxCliqueSearch(const AdjacencyMatrix& graph, long max_branches)
      : graph_(graph), budget_(max_branches) {}

  std::vector<int> run(const std::vector<int>& among) {
    // Vertices by decreasing degree within `among`: colouring in that order gives tight bounds.
    std::vector<int> order = among;
    std::vector<int> degree(static_cast<std::size_t>(graph_.size()), 0);
    for (int v : among)
      for (int u : among) degree[static_cast<std::size_t>(v)] += graph_.connected(v, u) ? 1 : 0;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return degree[static_cast<std::size_t>(a)] > degree[static_cast<std::size_t>(b)];
    });
    expand(order);
    if (best_.empty()) best_.push_back(order.front());  // budget gone before the first leaf
    std::sort(best_.begin(), best_.end());
    return best_;
  }

 private:
  // Greedy colouring of `candidates` (in order); returns them sorted by colour with each one's
  // colour number, an upper bound on the clique size they can still add.
  void colourSort(const std::vector<int>& candidates, std::vector<int>& sorted,
                  std::vector<int>& colour) const {
    std::vector<std::vector<int>> classes;
    for (int v : candidates) {
      std::size_t k = 0;
      while (k < classes.size() && std::any_of(classes[k].begin(), classes[k].end(),
                                               [&](int u) { return graph_.connected(u, v); })) {
        ++k;
      }
      if (k == classes.size()) classes.emplace_back();
      classes[k].push_back(v);
    }
    sorted.clear();
    colour.clear();
    for (std::size_t k = 0; k < classes.size(); ++k) {
      for (int v : classes[k]) {
        sorted.push_back(v);
        colour.push_back(static_cast<int>(k) + 1);
      }
    }
  }

  void expand(const std::vector<int>& candidates) {
    std::vector<int> sorted, colour;
    colourSort(candidates, sorted, colour);
    for (std::size_t i = sorted.size(); i-- > 0;) {
      if (current_.size() + static_cast<std::size_t>(colour[i]) <= best_.size()) return;
      if (budget_-- <= 0) return;
      const int v = sorted[i];
      current_.push_back(v);
      std::vector<int> next;
      for (std::size_t k = 0; k < i; ++k) {
        if (graph_.connected(v, sorted[k])) next.push_back(sorted[k]);
      }
      if (next.empty()) {
        if (current_.size() > best_.size()) best_ = current_;
      } else {
        expand(next);
      }
      current_.pop_back();
    }
  }

  const AdjacencyMatrix& graph_;
  long budget_;
  std::vector<int> current_;
  std::vector<int> best_;
};

}  // namespace

std::vector<int> maximumClique(const AdjacencyMatrix& graph, const std::vector<int>& among,
                               long max_branches) {
  std::vector<int> vertices = among;
  if (vertices.empty()) {
    for (int v = 0; v < graph.size(); ++v) vertices.push_back(v);
  }
  if (vertices.empty()) return {};
  return MaxCliqueSearch(graph, max_branches).run(vertices);
}

std::vector<int> heuristicMaximumClique(const AdjacencyMatrix& graph) {
  const int n = graph.size();
  const std::size_t words = graph.words();
  std::vector<int> degree(static_cast<std::size_t>(n), 0);
  for (int v = 0; v < n; ++v) {
    const std::uint64_t* row = graph.row(v);
    for (std::size_t w = 0; w < words; ++w) {
      degree[static_cast<std::size_t>(v)] += __builtin_popcountll(row[w]);
    }
  }
  std::vector<int> order(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) order[static_cast<std::size_t>(v)] = v;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return degree[static_cast<std::size_t>(a)] > degree[static_cast<std::size_t>(b)];
  });
  std::vector<int> best, clique;
  std::vector<std::uint64_t> common(words);
  auto in = [&](int v) {
    return (common[static_cast<std::size_t>(v) / 64] >> (static_cast<unsigned>(v) % 64)) & 1U;
  };
  for (int start : order) {
    // A clique larger than the best needs degree >= best.size() of each of its vertices.
    if (degree[static_cast<std::size_t>(start)] < static_cast<int>(best.size())) break;
    clique.assign(1, start);
    const std::uint64_t* row = graph.row(start);
    common.assign(row, row + words);
    for (int v : order) {
      if (!in(v) || degree[static_cast<std::size_t>(v)] < static_cast<int>(best.size())) continue;
      clique.push_back(v);
      const std::uint64_t* next = graph.row(v);
      for (std::size_t w = 0; w < words; ++w) common[w] &= next[w];
    }
    if (clique.size() > best.size()) best = clique;
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace rrr_graphslam::core
