#include "rrr_graphslam/frontend/scan_matcher.h"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace rrr_graphslam::frontend {

CorrelativeMatch realTimeCorrelativeMatch(const MatchGrid& grid, const core::Pose2& prediction,
                                          const PointCloud& points,
                                          const CorrelativeParams& params) {
  const double resolution = grid.resolution();
  const int window = static_cast<int>(std::ceil(params.linear_window_m / resolution));
  const int num_angles =
      params.angular_step_rad > 0.0
          ? static_cast<int>(std::ceil(params.angular_window_rad / params.angular_step_rad))
          : 0;
  core::Pose2 best = prediction;
  double best_score = 0.0;
  std::vector<Eigen::Array2i> cells(points.size());
  for (int k = -num_angles; k <= num_angles; ++k) {
    const double dtheta = k * params.angular_step_rad;
    const Eigen::Matrix2d R = core::rotation(prediction.z() + dtheta);
    for (std::size_t i = 0; i < points.size(); ++i) {
      cells[i] = grid.cellOf(prediction.head<2>() + R * points[i]);
    }
    for (int dx = -window; dx <= window; ++dx) {
      for (int dy = -window; dy <= window; ++dy) {
        double sum = 0.0;
        for (const auto& c : cells) sum += grid.at(c.x() + dx, c.y() + dy);
        const double dist2 = (dx * dx + dy * dy) * resolution * resolution;
        const double s = sum / static_cast<double>(points.size()) *
                         std::exp(-(params.translation_delta_cost_weight * dist2 +
                                    params.rotation_delta_cost_weight * dtheta * dtheta));
        if (s > best_score) {
          best_score = s;
          best = core::Pose2(prediction.x() + dx * resolution, prediction.y() + dy * resolution,
                             core::normalizeAngle(prediction.z() + dtheta));
        }
      }
    }
  }
  return {best, best_score};
}

RefinedMatch refineLeastSquares(const MatchGrid& grid, const core::Pose2& prior,
                                const core::Pose2& initial, const PointCloud& points,
                                const LeastSquaresParams& params) {
  const double n = static_cast<double>(std::max<std::size_t>(points.size(), 1));
  const double w_occ = params.occupied_space_weight / std::sqrt(n);
  core::Pose2 x = initial;
  Eigen::Matrix3d H_scan = Eigen::Matrix3d::Zero();
  double sum_sq = 0.0;
  double sum_p = 0.0;
  // Scan term at x: residuals and their squares, and (when H and g are given) the Gauss-Newton
  // Hessian and gradient; the line search needs only the cost.
  auto scanTerm = [&](const core::Pose2& pose, Eigen::Matrix3d* H, Eigen::Vector3d* g) {
    if (H != nullptr) {
      H->setZero();
      g->setZero();
    }
    sum_sq = 0.0;
    sum_p = 0.0;
    const Eigen::Matrix2d R = core::rotation(pose.z());
    for (const auto& p : points) {
      const Eigen::Vector2d rp = R * p;
      Eigen::Vector2d grad;
      const double m = grid.interpolate(pose.head<2>() + rp, H != nullptr ? &grad : nullptr);
      const double r = w_occ * (1.0 - m);
      if (H != nullptr) {
        // d(world point)/d(theta) = (-rp.y, rp.x)
        const Eigen::Vector3d J =
            -w_occ * Eigen::Vector3d(grad.x(), grad.y(), grad.x() * -rp.y() + grad.y() * rp.x());
        *H += J * J.transpose();
        *g += J * r;
      }
      sum_sq += r * r;
      sum_p += m;
    }
  };
  const double wt2 = params.translation_weight * params.translation_weight;
  const double wr2 = params.rotation_weight * params.rotation_weight;
  auto cost = [&](const core::Pose2& pose) {
    scanTerm(pose, nullptr, nullptr);
    return sum_sq + wt2 * (pose.head<2>() - prior.head<2>()).squaredNorm() +
           wr2 * std::pow(core::normalizeAngle(pose.z() - prior.z()), 2);
  };
  double current = cost(x);
  for (int it = 0; it < params.max_iterations; ++it) {
    Eigen::Matrix3d H;
    Eigen::Vector3d g;
    scanTerm(x, &H, &g);
    H(0, 0) += wt2;
    H(1, 1) += wt2;
    H(2, 2) += wr2;
    g.head<2>() += wt2 * (x.head<2>() - prior.head<2>());
    g.z() += wr2 * core::normalizeAngle(x.z() - prior.z());
    const Eigen::Vector3d step = -H.ldlt().solve(g);
    // Halve the step until the cost does not grow (the interpolated surface is only piecewise
    // smooth).
    double scale = 1.0;
    bool improved = false;
    for (int k = 0; k < 6 && !improved; ++k, scale *= 0.5) {
      core::Pose2 trial = x + scale * step;
      trial.z() = core::normalizeAngle(trial.z());
      const double c = cost(trial);
      if (c <= current) {
        x = trial;
        improved = current - c > 1e-12;
        current = c;
        if (!improved) break;
      }
    }
    if (!improved || step.norm() * scale < 1e-6) break;
  }
  Eigen::Vector3d g;
  scanTerm(x, &H_scan, &g);
  // Covariance of the scan term: sigma^2 H^-1 with sigma^2 the residual variance, plus the floor.
  const double dof = std::max(n - 3.0, 1.0);
  const double sigma2 = std::max(sum_sq / dof, 1e-9);
  Eigen::Matrix3d covariance = params.min_stddev.cwiseAbs2().asDiagonal();
  Eigen::Matrix3d H_reg = H_scan + 1e-9 * Eigen::Matrix3d::Identity();
  covariance += sigma2 * H_reg.inverse();
  RefinedMatch out;
  out.pose = x;
  out.mean_probability = sum_p / n;
  out.information = covariance.inverse();
  out.information = 0.5 * (out.information + out.information.transpose()).eval();
  return out;
}

}  // namespace rrr_graphslam::frontend
