#pragma once
// One laser scan as the front end uses it: the points to match (robot frame, range-limited,
// voxel-filtered) and the MRPT observation to insert into occupancy grids.

#include <string>

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

/// What of the laser a map's submaps and scans depend on: its beams, the angle they span and
/// where it sits on the robot (the heading is the aperture's centre). A map is continued only with
/// scans of the same setup (LaserSlam::addScan), up to what one sensor varies by: an interlacing
/// SICK (FR clinic's log) alternates 181 beams from -90 deg with 180 from -89.75, -89.5 and
/// -89.25 deg.
struct SensorSetup {
  int beams = 0;
  double aperture_rad = 0.0;  ///< beams x angle_increment
  core::Pose2 centre_in_robot = core::Pose2::Zero();

  static SensorSetup of(const RangeScan& scan);
  /// Of a scan as toObservation() made it.
  static SensorSetup of(const mrpt::obs::CObservation2DRangeScan& observation);
  /// The angle between beams within 1%, the aperture and its centre within two beams' angle (a
  /// full circle's centre is not compared: it is where the driver starts counting), and the
  /// position within 1 cm.
  bool sameAs(const SensorSetup& other) const;
  double beamAngle() const { return beams > 0 ? aperture_rad / beams : 0.0; }
  /// "N beams over A deg, centred at H deg, at (x, y) m on the robot".
  std::string describe() const;
};

/// Hit points in the robot frame within [min_range, max_range], one per voxel.
PointCloud matchingPoints(const RangeScan& scan, const RangeScanParams& params);

/// The scan for MRPT's grid insertion (only for that: see the aperture note in the source): rays
/// beyond max_range_m and misses are invalid, which MRPT clears as free space up to half the last
/// valid range.
mrpt::obs::CObservation2DRangeScan toObservation(const RangeScan& scan,
                                                 const RangeScanParams& params);

}  // namespace rrr_graphslam::frontend
