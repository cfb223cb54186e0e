#include "rrr_graphslam/frontend/local_slam.h"

namespace rrr_graphslam::frontend {

LocalSlam::LocalSlam(const LocalSlamParams& params)
    : params_(params), submaps_(params.submap), motion_filter_(params.motion_filter) {}

LocalSlamResult LocalSlam::addScan(const RangeScan& scan, const core::Pose2& odom_pose) {
  LocalSlamResult result;
  const core::Pose2 prediction =
      started_ ? core::compose(last_local_, core::between(last_odom_, odom_pose)) : odom_pose;
  started_ = true;
  result.local_pose = prediction;
  result.points = matchingPoints(scan, params_.scan);

  const auto submap = submaps_.matchingSubmap();
  if (submap && static_cast<int>(result.points.size()) >= params_.min_points) {
    const MatchGrid& grid = submap->matchGrid();
    const core::Pose2 initial =
        params_.correlative.linear_window_m > 0.0
            ? realTimeCorrelativeMatch(grid, prediction, result.points, params_.correlative)
            : prediction;
    if (params_.refinement == LocalSlamParams::Refinement::kIcp && submap->grid() != nullptr) {
      const auto icp = refineIcp(*submap->grid(), initial, result.points, params_.icp);
      result.local_pose = icp.value_or(initial);
    } else {
      // Cartographer's choice: translation pulled toward the prediction, rotation toward the
      // correlative result.
      const core::Pose2 prior(prediction.x(), prediction.y(), initial.z());
      result.local_pose =
          refineLeastSquares(grid, prior, initial, result.points, params_.least_squares).pose;
    }
    result.matched = true;
  }
  last_local_ = result.local_pose;
  last_odom_ = odom_pose;

  if (motion_filter_.accept(result.local_pose)) {
    const int node = next_node_++;
    result.node = node;
    result.observation = toObservation(scan, params_.scan);
    result.finished_submap = submaps_.insert(*result.observation, result.local_pose, node);
  }
  return result;
}

}  // namespace rrr_graphslam::frontend
