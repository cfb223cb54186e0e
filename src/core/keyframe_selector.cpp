#include "rrr_graphslam/core/keyframe_selector.h"

#include <cmath>
#include <stdexcept>

namespace rrr_graphslam::core {

KeyframeSelector::KeyframeSelector(const KeyframeParams& params) : params_(params) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(params.min_travel_m) || !positive(params.min_rotation_rad)) {
    throw std::invalid_argument("min_travel_m and min_rotation_rad must be positive");
  }
}

bool KeyframeSelector::accept(const Pose2& pose) {
  if (has_last_) {
    const Pose2 d = between(last_, pose);
    if (d.head<2>().norm() < params_.min_travel_m && std::abs(d[2]) < params_.min_rotation_rad) {
      return false;
    }
  }
  last_ = pose;
  has_last_ = true;
  return true;
}

}  // namespace rrr_graphslam::core
