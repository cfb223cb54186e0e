#include "rrr_graphslam/frontend/laser_slam_params.h"

namespace rrr_graphslam::frontend {

void validate(const LaserSlamParams& params) {
  forEachSlamParam(params, [](const core::ParamInfo& info, const auto& value) {
    core::checkRange(info, value);
  });
}

}  // namespace rrr_graphslam::frontend
