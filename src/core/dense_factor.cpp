#include "rrr_graphslam/core/dense_factor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "rrr_graphslam/core/constraint_check.h"

namespace rrr_graphslam::core {

namespace {

// r = e(x) - mean, the stacked edge errors from the root.
Eigen::VectorXd residual(const DenseFactor& factor, const std::vector<Pose2>& poses) {
  if (poses.size() != factor.nodes.size()) {
    throw std::invalid_argument("DenseFactor: " + std::to_string(poses.size()) + " poses for " +
                                std::to_string(factor.nodes.size()) + " nodes");
  }
  const auto k = static_cast<Eigen::Index>(factor.nodes.size() - 1);
  Eigen::VectorXd r(3 * k);
  for (Eigen::Index a = 0; a < k; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    r.segment<3>(3 * a) =
        edgeError(poses[0], poses[ua + 1], factor.measurements[ua]) - factor.mean.segment<3>(3 * a);
  }
  return r;
}

}  // namespace

std::string denseFactorProblem(const DenseFactor& factor) {
  const std::size_t n = factor.nodes.size();
  if (n < 2) return "it has " + std::to_string(n) + " nodes (at least two needed)";
  std::vector<mrpt::graphs::TNodeID> sorted = factor.nodes;
  std::sort(sorted.begin(), sorted.end());
  const auto twice = std::adjacent_find(sorted.begin(), sorted.end());
  if (twice != sorted.end()) return "node " + std::to_string(*twice) + " is listed twice";
  const auto rows = static_cast<Eigen::Index>(factor.dimension());
  if (factor.measurements.size() != n - 1 || factor.mean.size() != rows ||
      factor.information.rows() != rows || factor.information.cols() != rows) {
    return "its sizes do not match its " + std::to_string(n) + " nodes (" +
           std::to_string(factor.measurements.size()) + " measurements, mean of " +
           std::to_string(factor.mean.size()) + ", information " +
           std::to_string(factor.information.rows()) + " x " +
           std::to_string(factor.information.cols()) + "; expected " + std::to_string(n - 1) +
           ", " + std::to_string(rows) + ", " + std::to_string(rows) + " x " +
           std::to_string(rows) + ")";
  }
  for (std::size_t a = 0; a < factor.measurements.size(); ++a) {
    const std::string problem = poseProblem(factor.measurements[a]);
    if (!problem.empty()) return "measurement " + std::to_string(a) + ": " + problem;
  }
  if (!factor.mean.allFinite()) return "its mean is not finite";
  if (!factor.information.allFinite()) return "its information is not finite";
  const double scale = factor.information.cwiseAbs().maxCoeff();
  if ((factor.information - factor.information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return "its information is not symmetric";
  }
  if (Eigen::LLT<Eigen::MatrixXd>(factor.information).info() != Eigen::Success) {
    return "its information is not positive definite";
  }
  if (!(std::isfinite(factor.chi2_offset) && factor.chi2_offset >= 0.0)) {
    return "its chi2 offset " + std::to_string(factor.chi2_offset) + " is not a finite value >= 0";
  }
  return {};
}

DenseFactorLinearization linearize(const DenseFactor& factor, const std::vector<Pose2>& poses) {
  if (poses.size() != factor.nodes.size()) {
    throw std::invalid_argument("DenseFactor linearize: " + std::to_string(poses.size()) +
                                " poses for " + std::to_string(factor.nodes.size()) + " nodes");
  }
  // Residual row block a (a = 0 .. k-1) depends on the root (J_from) and on node a + 1 (J_to):
  // J = [F | T] with F the stacked J_from and T = blockdiag(J_to).
  const auto k = static_cast<Eigen::Index>(factor.nodes.size() - 1);
  Eigen::VectorXd r(3 * k);
  Eigen::MatrixXd F(3 * k, 3);
  std::vector<Eigen::Matrix3d> T(static_cast<std::size_t>(k));
  for (Eigen::Index a = 0; a < k; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    const EdgeLinearization lin = linearizeEdge(poses[0], poses[ua + 1], factor.measurements[ua]);
    r.segment<3>(3 * a) = lin.error - factor.mean.segment<3>(3 * a);
    F.middleRows<3>(3 * a) = lin.J_from;
    T[ua] = lin.J_to;
  }
  const Eigen::VectorXd omega_r = factor.information * r;
  // W = Omega T, G = Omega F.
  Eigen::MatrixXd W(3 * k, 3 * k);
  for (Eigen::Index b = 0; b < k; ++b) {
    W.middleCols<3>(3 * b).noalias() =
        factor.information.middleCols<3>(3 * b) * T[static_cast<std::size_t>(b)];
  }
  const Eigen::MatrixXd G = factor.information * F;

  DenseFactorLinearization out;
  out.chi2 = r.dot(omega_r) + factor.chi2_offset;
  out.information.resize(3 * (k + 1), 3 * (k + 1));
  out.gradient.resize(3 * (k + 1));
  out.information.topLeftCorner<3, 3>().noalias() = F.transpose() * G;  // F^T Omega F
  out.gradient.head<3>().noalias() = F.transpose() * omega_r;
  const Eigen::MatrixXd root_others = F.transpose() * W;  // F^T Omega T
  out.information.block(0, 3, 3, 3 * k) = root_others;
  out.information.block(3, 0, 3 * k, 3) = root_others.transpose();
  for (Eigen::Index a = 0; a < k; ++a) {
    const Eigen::Matrix3d& Ta = T[static_cast<std::size_t>(a)];
    out.gradient.segment<3>(3 * (a + 1)).noalias() = Ta.transpose() * omega_r.segment<3>(3 * a);
    out.information.block(3 * (a + 1), 3, 3, 3 * k).noalias() =
        Ta.transpose() * W.middleRows<3>(3 * a);  // T^T Omega T, row block a
  }
  return out;
}

double denseFactorChi2(const DenseFactor& factor, const std::vector<Pose2>& poses) {
  const Eigen::VectorXd r = residual(factor, poses);
  return r.dot(factor.information * r) + factor.chi2_offset;
}

}  // namespace rrr_graphslam::core
