#pragma once
// One laser scan as the front end uses it: the points to match (robot frame, range-limited,
// voxel-filtered) and the MRPT observation to insert into occupancy grids.

#include <mrpt/obs/CObservation2DRangeScan.h>

#include "rrr_graphslam/frontend/branch_and_bound.h"
#include "rrr_graphslam/frontend/carmen_log.h"

namespace rrr_graphslam::frontend {

struct RangeScanParams {
  double min_range_m = 0.1;    ///< closer readings are dropped (the robot itself)
  double max_range_m = 30.0;   ///< farther readings are not matched nor inserted as hits
  double voxel_size_m = 0.05;  ///< one matching point per voxel
};

/// A scan in sensor_msgs/LaserScan terms (CARMEN records and ROS messages both become this).
struct RangeScan {
  double timestamp = 0.0;
  double angle_min = 0.0;
  double angle_increment = 0.0;
  double max_range = 0.0;  ///< readings at or above it (or non-finite) are misses
  std::vector<float> ranges;
  core::Pose2 laser_in_robot = core::Pose2::Zero();

  static RangeScan fromCarmen(const LaserRecord& record);
  bool isMiss(std::size_t i) const { return !std::isfinite(ranges[i]) || ranges[i] >= max_range; }
};

/// Hit points in the robot frame within [min_range, max_range], one per voxel.
PointCloud matchingPoints(const RangeScan& scan, const RangeScanParams& params);

/// The scan for MRPT's grid insertion (only for that: see the aperture note in the source): rays
/// beyond max_range_m and misses are invalid, which MRPT clears as free space up to half the last
/// valid range.
mrpt::obs::CObservation2DRangeScan toObservation(const RangeScan& scan,
                                                 const RangeScanParams& params);

}  // namespace rrr_graphslam::frontend
