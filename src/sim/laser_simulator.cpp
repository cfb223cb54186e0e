#include "rrr_graphslam/sim/laser_simulator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

namespace rrr_graphslam::sim {

LaserSimulator::LaserSimulator(const World& world, const LaserParams& params)
    : params_(params), origin_m_(world.origin_m) {
  if (params.beam_count < 2 || !(params.angle_increment_rad > 0.0) || !(params.max_range_m > 0.0) ||
      !(params.range_stddev_m >= 0.0) || !(params.ray_cast_resolution_m > 0.0)) {
    throw std::invalid_argument(
        "LaserSimulator: beam_count must be at least 2, the increment, the maximum range and the "
        "ray-cast resolution positive, the noise non-negative");
  }
  // MRPT starts and steps its rays in fixed point at 1/1024 of a cell but returns whole steps
  // (0.8 cells): a finer copy of the world keeps that quantization below a centimetre.
  // At most 64 million fine cells (64 MB): a large world is cast coarser.
  int factor = std::max(
      1, static_cast<int>(std::ceil(world.resolution_m / params.ray_cast_resolution_m - 1e-9)));
  const double cells = static_cast<double>(world.width) * static_cast<double>(world.height);
  while (factor > 1 && cells * factor * factor > 64e6) --factor;
  const double fine_m = world.resolution_m / factor;
  // The grid's corner at (0, 0): MRPT rounds a grid's limits to whole cells, the world's origin
  // need not be a multiple of its resolution.
  grid_ = std::make_unique<mrpt::maps::COccupancyGridMap2D>(
      0.0F, static_cast<float>(world.width * world.resolution_m), 0.0F,
      static_cast<float>(world.height * world.resolution_m), static_cast<float>(fine_m));
  const int fine_width = world.width * factor, fine_height = world.height * factor;
  if (static_cast<int>(grid_->getSizeX()) < fine_width ||
      static_cast<int>(grid_->getSizeY()) < fine_height) {
    throw std::logic_error("LaserSimulator: MRPT's grid is smaller than the world");
  }
  grid_->fill(0.0F);  // beyond the world: solid
  for (int fy = 0; fy < fine_height; ++fy) {
    for (int fx = 0; fx < fine_width; ++fx) {
      // MRPT's cells hold the probability of being free; unknown cells are solid.
      if (world.at(fx / factor, fy / factor) == Cell::kFree) grid_->setCell(fx, fy, 1.0F);
    }
  }
}

LaserSimulator::~LaserSimulator() = default;

std::vector<float> LaserSimulator::scan(const core::Pose2& robot_in_world,
                                        std::mt19937_64* rng) const {
  const int n = params_.beam_count;
  const double aperture = (n - 1) * params_.angle_increment_rad;
  // MRPT marches each ray in steps of RAYTRACE_STEP_SIZE_IN_CELL_UNITS cells, returns the range
  // of the first step inside a solid cell (up to a step long: half a step is taken off) and stops
  // after maxRange / resolution steps, short of maxRange for a step below one cell.
  const double step_m =
      mrpt::maps::COccupancyGridMap2D::RAYTRACE_STEP_SIZE_IN_CELL_UNITS * grid_->getResolution();
  mrpt::obs::CObservation2DRangeScan obs;
  obs.aperture = static_cast<float>(aperture);
  obs.rightToLeft = true;
  obs.maxRange = static_cast<float>(params_.max_range_m * grid_->getResolution() / step_m +
                                    2.0 * grid_->getResolution());
  // MRPT fans the beams symmetrically about the sensor's heading.
  const core::Pose2& m = params_.laser_in_robot;
  obs.sensorPose = mrpt::poses::CPose3D(m.x(), m.y(), 0.0,
                                        m.z() + params_.angle_min_rad + 0.5 * aperture, 0.0, 0.0);
  const mrpt::poses::CPose2D robot(robot_in_world.x() - origin_m_.x(),
                                   robot_in_world.y() - origin_m_.y(), robot_in_world.z());
  grid_->laserScanSimulator(obs, robot, 0.5F, static_cast<std::size_t>(n));
  std::vector<float> ranges(static_cast<std::size_t>(n));
  std::normal_distribution<double> gauss(0.0, params_.range_stddev_m);
  const auto max_range = static_cast<float>(params_.max_range_m);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double r = obs.getScanRange(k) - 0.5 * step_m;
    if (!obs.getScanRangeValidity(k) || !(r < params_.max_range_m)) {
      ranges[k] = max_range;
      continue;
    }
    const double noisy = rng != nullptr && params_.range_stddev_m > 0.0 ? r + gauss(*rng) : r;
    // Noise never turns a return into a "no return" or a negative reading.
    ranges[k] = std::clamp(static_cast<float>(noisy), 0.0F, std::nextafter(max_range, 0.0F));
  }
  return ranges;
}

}  // namespace rrr_graphslam::sim
