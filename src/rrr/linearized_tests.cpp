#include "rrr_graphslam/rrr/linearized_tests.h"

#include <exception>

#include <Eigen/Dense>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/rrr/consistency.h"

namespace rrr_graphslam::rrr {
namespace {

// The links linearized at `poses`, with the map's covariance of the nodes they touch (from the
// optimizer's last factorization).
struct LinksLinearization {
  Eigen::VectorXd residual;         // 3 per link
  Eigen::MatrixXd link_covariance;  // block diagonal
  Eigen::MatrixXd map_term;         // J Sigma_map J^T
};

LinksLinearization linearizeLinks(const VerificationGraph& graph, const std::vector<int>& links,
                                  const std::vector<core::Pose2>& poses) {
  const auto rows = 3 * static_cast<Eigen::Index>(links.size());
  LinksLinearization out;
  out.residual.resize(rows);
  out.link_covariance = Eigen::MatrixXd::Zero(rows, rows);
  std::vector<core::Optimizer::JacobianBlock> J;
  J.reserve(2 * links.size());
  for (std::size_t i = 0; i < links.size(); ++i) {
    const LoopCandidate& c = graph.candidate(links[i]);
    const core::EdgeLinearization lin =
        core::linearizeEdge(poses[static_cast<std::size_t>(c.from)],
                            poses[static_cast<std::size_t>(c.to)], c.measurement);
    const auto r = 3 * static_cast<Eigen::Index>(i);
    out.residual.segment<3>(r) = lin.error;
    J.push_back({static_cast<int>(i), c.from, lin.J_from});
    J.push_back({static_cast<int>(i), c.to, lin.J_to});
    out.link_covariance.block<3, 3>(r, r) = c.information.inverse();
  }
  out.map_term = graph.optimizer().projectedCovariance(J, static_cast<int>(links.size()));
  return out;
}

}  // namespace

std::optional<double> predictedIndex(const VerificationGraph& graph, const std::vector<int>& links,
                                     const std::vector<core::Pose2>& poses, double alpha) {
  if (!graph.optimizer().covarianceAvailable() || links.empty()) return std::nullopt;
  const LinksLinearization lin = linearizeLinks(graph, links, poses);
  // Adding the links: the innovation covariance is the links' plus the map's.
  const Eigen::MatrixXd S = lin.link_covariance + lin.map_term;
  const double d2 = lin.residual.dot(S.ldlt().solve(lin.residual));
  return failIfNotFinite(d2 / core::chi2Quantile(alpha, static_cast<int>(lin.residual.size())));
}

std::optional<double> mapUncertaintyRatio(const VerificationGraph& graph,
                                          const std::vector<int>& links,
                                          const std::vector<core::Pose2>& poses) {
  if (!graph.optimizer().covarianceAvailable() || links.empty()) return std::nullopt;
  const LinksLinearization lin = linearizeLinks(graph, links, poses);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> ratio(
      lin.map_term, lin.link_covariance, Eigen::EigenvaluesOnly);
  if (ratio.info() != Eigen::Success) return std::nullopt;
  return failIfNotFinite(ratio.eigenvalues().maxCoeff());
}

double leaveOneOutIndex(const VerificationGraph& graph, const std::vector<int>& links,
                        const std::vector<core::Pose2>& poses, double alpha) {
  if (links.empty()) return 0.0;
  const LinksLinearization lin = linearizeLinks(graph, links, poses);
  // Removing links the map already contains: their own share comes off their covariance.
  const Eigen::MatrixXd S = lin.link_covariance - lin.map_term;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  if (ldlt.info() != Eigen::Success || (ldlt.vectorD().array() <= 0.0).any()) return 0.0;
  const double d2 = lin.residual.dot(ldlt.solve(lin.residual));
  return failIfNotFinite(d2 / core::chi2Quantile(alpha, static_cast<int>(lin.residual.size())));
}

std::vector<double> leaveOneOutIndices(const VerificationGraph& graph,
                                       const std::vector<const std::vector<int>*>& link_sets,
                                       const std::vector<core::Pose2>& poses, double alpha) {
  std::vector<double> index(link_sets.size(), 0.0);
  // An exception may not leave a parallel region: the first set's (as in a serial loop) is
  // rethrown after it.
  std::vector<std::exception_ptr> failure(link_sets.size());
  const auto n = static_cast<long>(link_sets.size());
  // A few sets are done on this thread: waking the team (and, with the other cores busy,
  // waiting for it at the barrier) would cost more than it saves.
  constexpr long kParallelFrom = 16;
#pragma omp parallel for schedule(dynamic) if (n >= kParallelFrom)
  for (long i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    try {
      index[k] = leaveOneOutIndex(graph, *link_sets[k], poses, alpha);
    } catch (...) {
      failure[k] = std::current_exception();
    }
  }
  for (const std::exception_ptr& f : failure) {
    if (f) std::rethrow_exception(f);
  }
  return index;
}

}  // namespace rrr_graphslam::rrr
