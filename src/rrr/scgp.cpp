#include "rrr_graphslam/rrr/scgp.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/pairwise_consistency.h"

namespace rrr_graphslam::rrr {
namespace {

struct ClusterDecision {
  std::vector<int> accepted;  // positions in the cluster
  double ratio = 0.0;         // l1 / l2 (infinite when l2 <= 0)
  bool unique = false;
};

ClusterDecision partition(const VerificationGraph& graph, const std::vector<int>& members,
                          double min_ratio) {
  const auto n = static_cast<Eigen::Index>(members.size());
  ClusterDecision out;
  if (n == 1) {
    out.accepted = {0};
    out.ratio = std::numeric_limits<double>::infinity();
    out.unique = true;
    return out;
  }
  // 1. Consistency matrix.
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const std::optional<double> d2 = pairwiseCycleChi2(
          graph, members[static_cast<std::size_t>(i)], members[static_cast<std::size_t>(j)]);
      A(i, j) = A(j, i) = d2 ? std::exp(-0.5 * *d2) : 1.0;
    }
  }
  // 2. Dominant eigenvector (eigenvalues ascending).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(A);
  const double l1 = eigen.eigenvalues()(n - 1);
  const double l2 = eigen.eigenvalues()(n - 2);
  Eigen::VectorXd v = eigen.eigenvectors().col(n - 1);
  if (v.sum() < 0.0) v = -v;
  // 3. Discretization: the densest prefix in decreasing order of v.
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return v(a) > v(b); });
  double sum = 0.0, best = -1.0;
  std::size_t best_size = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const int add = order[k];
    sum += A(add, add);
    for (std::size_t q = 0; q < k; ++q) sum += 2.0 * A(add, order[q]);
    const double density = sum / static_cast<double>(k + 1);
    if (density > best) {
      best = density;
      best_size = k + 1;
    }
  }
  // 4. Local uniqueness.
  out.ratio = l2 > 0.0 ? l1 / l2 : std::numeric_limits<double>::infinity();
  out.unique = out.ratio >= min_ratio;
  if (out.unique) out.accepted.assign(order.begin(), order.begin() + best_size);
  return out;
}

}  // namespace

VerifierDecisions decideScgp(VerificationGraph& graph, const ScgpParams& params) {
  if (!(params.ratio >= 1.0)) {
    throw std::invalid_argument("scgp: ratio = " + std::to_string(params.ratio) +
                                " is out of range: must be at least 1");
  }
  if (params.cluster_gap < 0) throw std::invalid_argument("scgp: cluster_gap must be >= 0");
  const auto start = std::chrono::steady_clock::now();
  const int m = graph.numCandidates();
  // RRR's time clusters (batch_rrr.cpp): the same candidates grouped the same way.
  const std::vector<CandidateEnds> ends = candidateEnds(graph);
  const int gap = params.cluster_gap > 0 ? params.cluster_gap : deriveClusterGap(ends);
  std::vector<int> session_of(static_cast<std::size_t>(graph.numNodes()));
  for (int n = 0; n < graph.numNodes(); ++n) {
    session_of[static_cast<std::size_t>(n)] = graph.chain().session(n);
  }
  const std::vector<std::vector<int>> clusters = clusterCandidates(ends, gap, session_of);

  VerifierDecisions out;
  out.verdicts.assign(static_cast<std::size_t>(m), Verdict::kRejected);
  out.cluster_of.assign(static_cast<std::size_t>(m), -1);
  out.reasons.resize(static_cast<std::size_t>(m));
  std::vector<int> accepted;
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    const std::vector<int>& members = clusters[c];
    const ClusterDecision d = partition(graph, members, params.ratio);
    std::vector<char> in(members.size(), 0);
    for (int p : d.accepted) in[static_cast<std::size_t>(p)] = 1;
    char what[160];
    for (std::size_t p = 0; p < members.size(); ++p) {
      const auto k = static_cast<std::size_t>(members[p]);
      out.cluster_of[k] = static_cast<int>(c);
      if (!d.unique) {
        std::snprintf(what, sizeof(what),
                      "scgp: cluster of %zu ambiguous (l1/l2 = %.2f < %.2f): none accepted",
                      members.size(), d.ratio, params.ratio);
      } else {
        std::snprintf(what, sizeof(what), "scgp: %s the dominant group (%zu of %zu, l1/l2 = %.2f)",
                      in[p] ? "in" : "outside", d.accepted.size(), members.size(), d.ratio);
      }
      out.reasons[k] = what;
      if (in[p]) {
        out.verdicts[k] = Verdict::kAccepted;
        accepted.push_back(members[p]);
      }
    }
  }
  std::sort(accepted.begin(), accepted.end());
  out.summary.clusters = static_cast<int>(clusters.size());
  out.summary.cluster_gap = gap;
  finishDecisions(graph, accepted, start, out);
  return out;
}

}  // namespace rrr_graphslam::rrr
