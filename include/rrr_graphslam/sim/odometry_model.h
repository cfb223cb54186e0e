#pragma once
// Wheel odometry with drift: each true step between two samples, in the robot's frame, is read
// with zero-mean Gaussian errors whose variances grow linearly with the distance driven and the
// angle turned, so the dead-reckoned pose drifts as a random walk whose spread does not depend on
// the sampling rate (after L metres straight, the along-track error has a standard deviation of
// forward_stddev * sqrt(L)). The odometry frame is the session's own: its first pose is given.

#include <random>
#include <vector>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::sim {

struct OdometryNoise {
  double forward_stddev = 0.02;         ///< m per sqrt(m driven) (default 0.02)
  double lateral_stddev = 0.01;         ///< m per sqrt(m driven) (default 0.01)
  double yaw_per_turn_stddev = 0.02;    ///< rad per sqrt(rad turned) (default 0.02)
  double yaw_per_meter_stddev = 0.005;  ///< rad per sqrt(m driven) (default 0.005)

  bool isZero() const {
    return forward_stddev == 0.0 && lateral_stddev == 0.0 && yaw_per_turn_stddev == 0.0 &&
           yaw_per_meter_stddev == 0.0;
  }
};

/// The odometry reading of every true pose: reading[0] = odom_start, reading[k] = reading[k-1]
/// (+) (the true step from k-1 to k, with noise). With zero noise, reading[k] = odom_start (+)
/// (truth[0]^-1 (+) truth[k]).
std::vector<core::Pose2> simulateOdometry(const std::vector<core::Pose2>& truth,
                                          const core::Pose2& odom_start, const OdometryNoise& noise,
                                          std::mt19937_64& rng);

}  // namespace rrr_graphslam::sim
