#include "rrr_graphslam/frontend/laser_slam_params.h"

#include <sstream>
#include <stdexcept>

namespace rrr_graphslam::frontend {

void validate(const LaserSlamParams& params) {
  forEachSlamParam(params, [](const core::ParamInfo& info, const auto& value) {
    core::checkRange(info, value);
  });
  const SubmapParams& submap = params.local.submap;
  // The ambiguity search leaves out the match's own place; one smaller than two cells of the
  // branch-and-bound grid leaves the match's own peak in and calls every match ambiguous.
  const double search_cell = submap.resolution_m * submap.search_grid_factor;
  if (params.loops.ambiguity_ratio < 1.0 &&
      params.loops.ambiguity_exclusion.linear_m < 2.0 * search_cell) {
    std::ostringstream s;
    s << "loop_ambiguity_distance = " << params.loops.ambiguity_exclusion.linear_m
      << " m is below two cells of the branch-and-bound grid (" << 2.0 * search_cell
      << " m: submap_resolution x search_grid_factor): the match's own peak would be its alias";
    throw std::invalid_argument(s.str());
  }
}

}  // namespace rrr_graphslam::frontend
