#pragma once
// A differential-drive robot following a path with pure pursuit (Coulter 1992): it steers towards
// the point of the path `lookahead_m` ahead, turns in place when that point is far off its
// heading, and stops at the path's end. The unicycle is integrated in small substeps; its pose is
// sampled every `period_s` (the scan period).

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::sim {

struct MotionParams {
  double max_speed_mps = 0.4;        ///< m/s (default 0.4, a typical indoor platform)
  double max_turn_rate_radps = 0.8;  ///< rad/s (default 0.8)
  double lookahead_m = 0.5;          ///< m; pure pursuit's lookahead distance (default 0.5)
  double turn_gain = 2.0;            ///< 1/s; turn rate per radian of heading error (default 2)
  /// rad; beyond this heading error the robot turns in place (default 1.0, ~57 degrees).
  double turn_in_place_rad = 1.0;
  double goal_tolerance_m = 0.05;  ///< m; the end counts as reached within this (default 0.05)
};

/// A pose every `period_s` from `start` until the end of `path` (world points) is reached or
/// `max_samples` poses were taken; the first sample is `start`.
std::vector<core::Pose2> followPath(const std::vector<Eigen::Vector2d>& path,
                                    const core::Pose2& start, const MotionParams& params,
                                    double period_s, std::size_t max_samples);

}  // namespace rrr_graphslam::sim
