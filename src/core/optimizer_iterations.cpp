// Optimizer, the iterations: Gauss-Newton with chord steps near the minimum, and
// Levenberg-Marquardt with Marquardt's scaling, which Gauss-Newton hands over to when a full step
// raises chi2.

#include <algorithm>
#include <cmath>
#include <limits>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/stopwatch.h"

namespace rrr_graphslam::core {

void Optimizer::gaussNewton(OptimizationResult& result, double& chi2_now, bool start_with_factor,
                            std::chrono::steady_clock::time_point& clock) {
  auto& timing = result.timing;
  // An updated factor serves covariance() too, linearized partly at earlier poses.
  covariance_valid_ = start_with_factor;
  // Near the minimum H hardly changes between steps, so the last factorization is reused
  // (chord steps: new gradient, old factor) while that still shrinks the chi2 decrease fast.
  // The fixed point is the same (gradient = 0); a chord step that does not lower chi2 is
  // undone and followed by a fresh factorization. A full step that raises chi2 (far from the
  // minimum, e.g. with gross outliers switched on) is undone and Levenberg-Marquardt takes over.
  // A factor brought up to date by rank updates starts the run in the same (chord) mode.
  bool reuse_factor = start_with_factor;
  double last_decrease = start_with_factor ? std::numeric_limits<double>::infinity() : 0.0;
  // H is assembled only where a factorization may follow; chord steps need the gradient alone
  // (optimize() assembled H unless it starts from an updated factor).
  bool hessian_current = !start_with_factor;
  while (result.iterations < params_.max_iterations) {
    if (cancelled()) {
      result.stop_reason = StopReason::kCancelled;
      return;
    }
    if (!reuse_factor) {
      if (!hessian_current) {
        assemble();
        timing.assemble_sec += lap(clock);
      }
      const bool factorized = solver_.factorize(hessian_.matrix());
      timing.factorize_sec += lap(clock);
      ++result.factorizations;
      covariance_valid_ = factorized;
      factor_valid_ = false;
      if (!factorized) {
        result.stop_reason = StopReason::kSingular;
        return;
      }
      rememberFactoredState();
    }
    const Eigen::VectorXd step = solver_.solve(Eigen::VectorXd(-gradient_));
    // The decrease the quadratic model still expects (half the Newton decrement, with this
    // factor's H). Below the tolerance the run has converged: near the minimum a stale factor's
    // step overshoots by about as much as it could gain, and would cost a fresh factorization.
    if (-0.5 * gradient_.dot(step) <= params_.relative_tolerance * chi2_now) {
      timing.solve_sec += lap(clock);
      result.stop_reason = StopReason::kConverged;
      return;
    }
    const std::vector<Pose2> saved = poses_;
    applyStep(step);
    timing.solve_sec += lap(clock);
    // The gradient alone: H is assembled only when a fresh factorization follows (most steps
    // after a fresh one are chord steps, which would not use it).
    hessian_current = false;
    const double chi2_next = assemble(false);
    timing.assemble_sec += lap(clock);
    const double decrease = chi2_now - chi2_next;
    // A step to a non-finite chi2 is never taken.
    if (!std::isfinite(chi2_next) ||
        (!(decrease > 0.0) &&
         (reuse_factor || decrease < -params_.relative_tolerance * chi2_now))) {
      poses_ = saved;
      chi2_now = assemble();
      hessian_current = true;
      timing.assemble_sec += lap(clock);
      if (reuse_factor) {
        reuse_factor = false;  // the stale factor overshot: refactorize here
        continue;
      }
      levenbergMarquardt(result, chi2_now, clock);
      return;
    }
    ++result.iterations;
    const bool small_decrease = decrease <= params_.relative_tolerance * chi2_now;
    const bool small_step = step.lpNorm<Eigen::Infinity>() <= params_.step_tolerance;
    reuse_factor = params_.reuse_factorization && decrease > 0.0 &&
                   (reuse_factor ? decrease < 0.5 * last_decrease : decrease < 0.3 * chi2_now);
    last_decrease = decrease;
    chi2_now = chi2_next;
    if (small_step || small_decrease) {
      result.stop_reason = StopReason::kConverged;
      return;
    }
  }
}

void Optimizer::levenbergMarquardt(OptimizationResult& result, double& chi2_now,
                                   std::chrono::steady_clock::time_point& clock) {
  auto& timing = result.timing;
  covariance_valid_ = false;  // damped factors describe no covariance
  factor_valid_ = false;      // nor an undamped H to update
  // Marquardt's scaling: damp each variable in proportion to its own curvature, which copes
  // with the mix of metres and radians and with far-off initial guesses (City10000, ringCity).
  Eigen::VectorXd diagonal = hessian_.diagonal();
  double lambda = params_.lm_tau;
  double nu = 2.0;
  int attempts = 0;
  while (result.iterations < params_.max_iterations) {
    if (cancelled()) {
      result.stop_reason = StopReason::kCancelled;
      return;
    }
    if (++attempts > 10 * params_.max_iterations + 50 || lambda > 1e30) {
      result.stop_reason = StopReason::kDiverged;
      return;
    }
    const Eigen::VectorXd damping = lambda * diagonal.cwiseMax(1e-12);
    hessian_.setDiagonal(diagonal + damping);
    const bool factorized = solver_.factorize(hessian_.matrix());
    hessian_.setDiagonal(diagonal);
    timing.factorize_sec += lap(clock);
    ++result.factorizations;
    if (!factorized) {
      lambda *= nu;
      nu *= 2.0;
      continue;
    }
    const Eigen::VectorXd step = solver_.solve(Eigen::VectorXd(-gradient_));
    const std::vector<Pose2> saved = poses_;
    applyStep(step);
    const double chi2_next = weightedChi2();
    timing.solve_sec += lap(clock);
    const double predicted = step.dot(damping.cwiseProduct(step) - gradient_);
    const double rho = (chi2_now - chi2_next) / std::max(predicted, 1e-300);
    // Also done when even the quadratic model sees nothing left to gain: near the minimum rho
    // is a ratio of rounding errors.
    const bool small_step = step.lpNorm<Eigen::Infinity>() <= params_.step_tolerance ||
                            predicted <= params_.relative_tolerance * chi2_now;
    if (rho > 0.0 && std::isfinite(chi2_next)) {
      ++result.iterations;
      // A small decrease means convergence only when the quadratic model predicted it well;
      // a heavily damped step also decreases chi2 little, without being near the minimum.
      const bool small_decrease =
          chi2_now - chi2_next <= params_.relative_tolerance * chi2_now && rho > 0.25;
      chi2_now = assemble();
      diagonal = hessian_.diagonal();
      timing.assemble_sec += lap(clock);
      lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
      if (small_decrease || small_step) {
        result.stop_reason = StopReason::kConverged;
        return;
      }
    } else {
      poses_ = saved;
      if (small_step) {
        result.stop_reason = StopReason::kConverged;
        return;
      }
      lambda *= nu;
      nu *= 2.0;
    }
  }
}

}  // namespace rrr_graphslam::core
