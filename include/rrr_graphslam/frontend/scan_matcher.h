#pragma once
// Scan-to-submap matching for local SLAM and for refining loop matches:
// 1. realTimeCorrelativeMatch: Olson's correlative search in a small window around the prediction,
//    every discrete pose scored, the score discounted by the distance from the prediction.
// 2. refineLeastSquares: Gauss-Newton on the interpolated probabilities,
//        sum_i (1 - M(T p_i))^2 / N * w_occ^2 + w_t^2 |t - t_prior|^2 + w_r^2 (theta -
//        theta_prior)^2
//    (Cartographer's Ceres scan matcher cost, here with bilinear interpolation and an analytic
//    3x3 Gauss-Newton step), which also yields the information matrix of the match.

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/branch_and_bound.h"
#include "rrr_graphslam/frontend/match_grid.h"

namespace rrr_graphslam::frontend {

struct CorrelativeParams {
  double linear_window_m = 0.15;
  double angular_window_rad = 10.0 * M_PI / 180;
  double angular_step_rad = 0.5 * M_PI / 180;
  /// Score discount exp(-(w_t |dt|^2 + w_r dtheta^2)) for straying from the prediction.
  double translation_delta_cost_weight = 0.1;
  double rotation_delta_cost_weight = 0.1;
};

struct LeastSquaresParams {
  double occupied_space_weight = 1.0;
  double translation_weight = 2.0;
  double rotation_weight = 10.0;
  int max_iterations = 20;
  /// Floor on the standard deviations (m, m, rad) of a match, added to the estimated covariance:
  /// no scan match is trusted more than this.
  Eigen::Vector3d min_stddev{0.02, 0.02, 0.2 * M_PI / 180};
};

struct RefinedMatch {
  core::Pose2 pose;
  double mean_probability;      ///< mean of M(T p_i) at the solution
  Eigen::Matrix3d information;  ///< of `pose`, from the Gauss-Newton Hessian of the scan term
};

struct CorrelativeMatch {
  core::Pose2 pose;    ///< the best discrete pose (the prediction when nothing scored above 0)
  double score = 0.0;  ///< its mean probability, discounted for straying from the prediction
};

/// The best discrete pose near `prediction`; `prediction` itself if no pose scores above zero.
CorrelativeMatch realTimeCorrelativeMatch(const MatchGrid& grid, const core::Pose2& prediction,
                                          const PointCloud& points,
                                          const CorrelativeParams& params);

/// Least-squares refinement starting at `initial`, pulled toward `prior`.
RefinedMatch refineLeastSquares(const MatchGrid& grid, const core::Pose2& prior,
                                const core::Pose2& initial, const PointCloud& points,
                                const LeastSquaresParams& params);

}  // namespace rrr_graphslam::frontend
