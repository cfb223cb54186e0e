#pragma once
// Which odometry poses become graph nodes: the first one, then each pose that moved at least
// min_travel_m or turned at least min_rotation_rad away from the last node (whichever first).

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

struct KeyframeParams {
  double min_travel_m = 0.5;      ///< default 0.5 m
  double min_rotation_rad = 0.5;  ///< default 0.5 rad (about 29 degrees)
};

class KeyframeSelector {
 public:
  /// Throws std::invalid_argument unless both thresholds are positive and finite.
  explicit KeyframeSelector(const KeyframeParams& params = {});

  /// True if `pose` should become a node; it then becomes the reference for the next one.
  bool accept(const Pose2& pose);
  void reset() { has_last_ = false; }

 private:
  KeyframeParams params_;
  bool has_last_ = false;
  Pose2 last_ = Pose2::Zero();
};

}  // namespace rrr_graphslam::core
