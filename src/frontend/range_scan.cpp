#include "rrr_graphslam/frontend/range_scan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/frontend/voxel_filter.h"

namespace rrr_graphslam::frontend {

RangeScan RangeScan::fromCarmen(const LaserRecord& record) {
  RangeScan scan;
  scan.timestamp = record.timestamp;
  scan.angle_min = record.angle_min;
  scan.angle_increment = record.angle_increment;
  scan.max_range = record.max_range;
  scan.ranges = record.ranges;
  scan.laser_in_robot = record.laserInRobot();
  return scan;
}

PointCloud matchingPoints(const RangeScan& scan, const RangeScanParams& params) {
  PointCloud points;
  points.reserve(scan.ranges.size());
  const Eigen::Matrix2d R = core::rotation(scan.laser_in_robot.z());
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.ranges[i];
    if (scan.isMiss(i) || r < params.min_range_m || r > params.max_range_m) continue;
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    points.push_back(scan.laser_in_robot.head<2>() +
                     R * Eigen::Vector2d(r * std::cos(a), r * std::sin(a)));
  }
  return voxelFilter(points, params.voxel_size_m);
}

SensorSetup SensorSetup::of(const RangeScan& scan) {
  SensorSetup setup;
  setup.beams = static_cast<int>(scan.ranges.size());
  setup.aperture_rad = static_cast<double>(setup.beams) * scan.angle_increment;
  setup.centre_in_robot = scan.laser_in_robot;
  setup.centre_in_robot.z() =
      core::normalizeAngle(scan.laser_in_robot.z() + scan.angle_min + 0.5 * setup.aperture_rad);
  return setup;
}

SensorSetup SensorSetup::of(const mrpt::obs::CObservation2DRangeScan& observation) {
  SensorSetup setup;
  setup.beams = static_cast<int>(observation.getScanSize());
  setup.aperture_rad = observation.aperture;
  setup.centre_in_robot = core::Pose2(observation.sensorPose.x(), observation.sensorPose.y(),
                                      core::normalizeAngle(observation.sensorPose.yaw()));
  return setup;
}

bool SensorSetup::sameAs(const SensorSetup& other) const {
  constexpr double kMaxOffset_m = 0.01;
  const double beam = beamAngle();
  const double coarser_beam = std::max(beam, other.beamAngle());
  const double two_beams = 2.0 * coarser_beam;
  // A full circle's centre is where its driver starts counting (angle_min 0 or -pi), not where
  // it looks.
  const bool full_circle = aperture_rad >= 2.0 * M_PI - two_beams;
  return beams > 0 && other.beams > 0 &&
         std::abs(beam - other.beamAngle()) <= 0.01 * coarser_beam &&
         std::abs(aperture_rad - other.aperture_rad) <= two_beams &&
         (full_circle || std::abs(core::normalizeAngle(centre_in_robot.z() -
                                                       other.centre_in_robot.z())) <= two_beams) &&
         (centre_in_robot.head<2>() - other.centre_in_robot.head<2>()).norm() <= kMaxOffset_m;
}

std::string SensorSetup::describe() const {
  char text[160];
  std::snprintf(text, sizeof(text),
                "%d beams %.3f deg apart over %.2f deg, centred at %.2f deg, at (%.3f, %.3f) m "
                "on the robot",
                beams, beamAngle() * 180.0 / M_PI, aperture_rad * 180.0 / M_PI,
                centre_in_robot.z() * 180.0 / M_PI, centre_in_robot.x(), centre_in_robot.y());
  return text;
}

mrpt::obs::CObservation2DRangeScan toObservation(const RangeScan& scan,
                                                 const RangeScanParams& params) {
  mrpt::obs::CObservation2DRangeScan obs;
  const std::size_t n = scan.ranges.size();
  // MRPT 2.5's grid insertion spaces the rays aperture/N apart starting at -aperture/2 (not
  // aperture/(N-1) as getScanAngle() does; test_scan_matcher checks the geometry): choose the
  // aperture and the sensor's heading so that ray i falls at angle_min + i * angle_increment.
  const SensorSetup setup = SensorSetup::of(scan);
  obs.aperture = static_cast<float>(setup.aperture_rad);
  obs.rightToLeft = true;
  obs.maxRange = static_cast<float>(params.max_range_m);
  obs.sensorPose = mrpt::poses::CPose3D(setup.centre_in_robot.x(), setup.centre_in_robot.y(), 0.0,
                                        setup.centre_in_robot.z(), 0.0, 0.0);
  obs.resizeScan(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float r = scan.ranges[i];
    const bool valid = !scan.isMiss(i) && r <= params.max_range_m && r >= params.min_range_m;
    obs.setScanRange(i, valid ? r : 0.0F);
    obs.setScanRangeValidity(i, valid);
  }
  return obs;
}

}  // namespace rrr_graphslam::frontend
