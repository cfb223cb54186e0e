#include "rrr_graphslam/sim/path_follower.h"

#include <algorithm>
#include <cmath>

namespace rrr_graphslam::sim {

std::vector<core::Pose2> followPath(const std::vector<Eigen::Vector2d>& path,
                                    const core::Pose2& start, const MotionParams& params,
                                    double period_s, std::size_t max_samples) {
  constexpr int kSubsteps = 10;
  std::vector<core::Pose2> samples{start};
  if (path.empty()) return samples;
  core::Pose2 x = start;
  std::size_t target = 0;  // the path point steered to; only moves forward
  const double dt = period_s / kSubsteps;
  while (samples.size() < max_samples) {
    for (int s = 0; s < kSubsteps; ++s) {
      // The first point at least lookahead_m away (or the last one).
      while (target + 1 < path.size() && (path[target] - x.head<2>()).norm() < params.lookahead_m) {
        ++target;
      }
      const Eigen::Vector2d to_target = path[target] - x.head<2>();
      const double distance = to_target.norm();
      if (target + 1 == path.size() && distance < params.goal_tolerance_m) return samples;
      const double error = core::normalizeAngle(std::atan2(to_target.y(), to_target.x()) - x.z());
      const double w = std::clamp(params.turn_gain * error, -params.max_turn_rate_radps,
                                  params.max_turn_rate_radps);
      double v = 0.0;
      if (std::abs(error) < params.turn_in_place_rad) {
        // Slower in turns and when arriving at the end.
        v = params.max_speed_mps * std::cos(error);
        if (target + 1 == path.size()) v = std::min(v, distance);
      }
      // The unicycle's exact motion over dt (an arc, or a straight line).
      if (std::abs(w) > 1e-9) {
        const double r = v / w;
        x.x() += r * (std::sin(x.z() + w * dt) - std::sin(x.z()));
        x.y() -= r * (std::cos(x.z() + w * dt) - std::cos(x.z()));
      } else {
        x.x() += v * dt * std::cos(x.z());
        x.y() += v * dt * std::sin(x.z());
      }
      x.z() = core::normalizeAngle(x.z() + w * dt);
    }
    samples.push_back(x);
  }
  return samples;
}

}  // namespace rrr_graphslam::sim
