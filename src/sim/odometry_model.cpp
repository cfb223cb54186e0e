#include "rrr_graphslam/sim/odometry_model.h"

#include <cmath>

namespace rrr_graphslam::sim {

std::vector<core::Pose2> simulateOdometry(const std::vector<core::Pose2>& truth,
                                          const core::Pose2& odom_start, const OdometryNoise& noise,
                                          std::mt19937_64& rng) {
  std::vector<core::Pose2> reading;
  if (truth.empty()) return reading;
  reading.reserve(truth.size());
  reading.push_back(odom_start);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (std::size_t k = 1; k < truth.size(); ++k) {
    core::Pose2 step = core::between(truth[k - 1], truth[k]);
    const double driven = step.head<2>().norm();
    const double turned = std::abs(step.z());
    // Drawn even with zero noise, so that the random sequence does not depend on the noise.
    const double n_forward = gauss(rng), n_lateral = gauss(rng), n_yaw = gauss(rng);
    if (!noise.isZero()) {
      step.x() += noise.forward_stddev * std::sqrt(driven) * n_forward;
      step.y() += noise.lateral_stddev * std::sqrt(driven) * n_lateral;
      step.z() += std::sqrt(noise.yaw_per_turn_stddev * noise.yaw_per_turn_stddev * turned +
                            noise.yaw_per_meter_stddev * noise.yaw_per_meter_stddev * driven) *
                  n_yaw;
    }
    reading.push_back(core::compose(reading.back(), step));
    reading.back().z() = core::normalizeAngle(reading.back().z());
  }
  return reading;
}

}  // namespace rrr_graphslam::sim
