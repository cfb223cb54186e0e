#include "rrr_graphslam/rrr/pairwise_consistency.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cstdlib>
#include <utility>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/max_clique.h"

namespace rrr_graphslam::rrr {
namespace {

using core::Pose2;

// A link as the cycle uses it: ends, measurement and its covariance (noise on the right).
struct OrientedLink {
  int from;
  int to;
  Pose2 z;
  Eigen::Matrix3d covariance;
};

OrientedLink oriented(const LoopCandidate& c, bool reverse) {
  const Eigen::Matrix3d covariance = c.information.inverse();
  if (!reverse) return {c.from, c.to, c.measurement, covariance};
  return {c.to, c.from, core::inverse(c.measurement),
          core::covarianceOfInverse(c.measurement, covariance)};
}

// Odometry noise between nodes p and q (same session) in the session frame: q's world-frame
// perturbation minus p's is sign * (sum of the steps in [low, high)).
struct OdometryPiece {
  int low;
  int high;
  double sign;
};

OdometryPiece piece(int p, int q) { return {std::min(p, q), std::max(p, q), q > p ? 1.0 : -1.0}; }

Eigen::Matrix3d pieceCovariance(const OdometryChain& chain, int low, int high) {
  if (high <= low) return Eigen::Matrix3d::Zero();
  const Eigen::Matrix3d s = chain.prefixCovariance(high) - chain.prefixCovariance(low);
  return 0.5 * (s + s.transpose());
}

}  // namespace

std::optional<double> pairwiseCycleChi2(const VerificationGraph& graph, int i, int j) {
  if (j < i) std::swap(i, j);  // linearized around the lower one's cycle: symmetric by design
  const LoopCandidate& ci = graph.candidate(i);
  const LoopCandidate& cj = graph.candidate(j);
  const bool reverse = std::abs(ci.from - cj.from) + std::abs(ci.to - cj.to) >
                       std::abs(ci.from - cj.to) + std::abs(ci.to - cj.from);
  const OrientedLink li = oriented(ci, false);
  const OrientedLink lj = oriented(cj, reverse);
  const int a = li.from, b = li.to, c = lj.from, d = lj.to;
  const OdometryChain& chain = graph.chain();
  if (!chain.sameSession(a, c) || !chain.sameSession(b, d)) return std::nullopt;

  // C = z_i (P_b^-1 P_d) z_j^-1 (P_c^-1 P_a); with world-frame perturbations w_k of the chain
  // poses (P_k -> Exp(w_k) P_k), u = w_d - w_b, v = w_a - w_c and right noise n_i, n_j on the
  // links, to first order C = Exp(Ad(M1) u + Ad(M2) v + Ad(z_i) n_i - Ad(N) n_j) C0 with
  // M1 = z_i P_b^-1, N = z_i P_b^-1 P_d, M2 = N z_j^-1 P_c^-1.
  const Pose2& Pa = chain.chainPose(a);
  const Pose2& Pb = chain.chainPose(b);
  const Pose2& Pc = chain.chainPose(c);
  const Pose2& Pd = chain.chainPose(d);
  const Pose2 N = core::compose(li.z, core::between(Pb, Pd));
  const Pose2 C0 = core::compose(core::compose(N, core::inverse(lj.z)), core::between(Pc, Pa));
  const Eigen::Matrix3d A1 = core::adjoint(core::compose(li.z, core::inverse(Pb)));
  const Eigen::Matrix3d A2 =
      core::adjoint(core::compose(core::compose(N, core::inverse(lj.z)), core::inverse(Pc)));
  const Eigen::Matrix3d Ai = core::adjoint(li.z);
  const Eigen::Matrix3d Aj = core::adjoint(N);

  const OdometryPiece u = piece(b, d);
  const OdometryPiece v = piece(c, a);
  Eigen::Matrix3d cov = A1 * pieceCovariance(chain, u.low, u.high) * A1.transpose() +
                        A2 * pieceCovariance(chain, v.low, v.high) * A2.transpose() +
                        Ai * li.covariance * Ai.transpose() + Aj * lj.covariance * Aj.transpose();
  if (chain.sameSession(a, b)) {
    // Both pieces in one session: the steps they share make u and v correlated.
    const Eigen::Matrix3d shared =
        u.sign * v.sign * pieceCovariance(chain, std::max(u.low, v.low), std::min(u.high, v.high));
    const Eigen::Matrix3d cross = A1 * shared * A2.transpose();
    cov += cross + cross.transpose();
  }
  Eigen::Vector3d r = C0;
  r(2) = core::normalizeAngle(r(2));
  return r.dot(cov.ldlt().solve(r));
}

std::vector<std::vector<int>> splitByPairwiseConsistency(const VerificationGraph& graph,
                                                         const std::vector<int>& links,
                                                         double alpha) {
  const int n = static_cast<int>(links.size());
  const double threshold = core::chi2Quantile(alpha, 3);
  core::AdjacencyMatrix consistent(n);
  for (int p = 0; p < n; ++p) {
    for (int q = p + 1; q < n; ++q) {
      const std::optional<double> d2 = pairwiseCycleChi2(graph, links[static_cast<std::size_t>(p)],
                                                         links[static_cast<std::size_t>(q)]);
      if (!d2 || *d2 < threshold) consistent.connect(p, q);
    }
  }
  std::vector<int> remaining(static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) remaining[static_cast<std::size_t>(p)] = p;
  std::vector<std::vector<int>> groups;
  while (!remaining.empty()) {
    const std::vector<int> clique = core::maximumClique(consistent, remaining);
    std::vector<int> group, rest;
    for (int p : remaining) {
      const bool in = std::binary_search(clique.begin(), clique.end(), p);
      (in ? group : rest).push_back(p);
    }
    for (int& p : group) p = links[static_cast<std::size_t>(p)];
    groups.push_back(std::move(group));
    remaining.swap(rest);
  }
  // Cliques come out largest first; equal sizes keep the order they were found in.
  return groups;
}

}  // namespace rrr_graphslam::rrr
