#pragma once
// Scan-to-submap refinement by MRPT's ICP (mrpt::slam::CICP, classic point-to-point ICP with
// shrinking correspondence thresholds) instead of the least-squares refinement: the scan's points
// are aligned with the occupied cells of the active submap's MRPT grid, starting from the
// correlative search's pose. An option of local SLAM (LocalSlamParams::refinement); the
// least-squares refinement stays the default: point-to-point ICP against cell centres is only
// accurate to about a cell (ACES relation error 0.0441 m with ICP against 0.0360 m, both before
// the trajectory refinement; see README).

#include <optional>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/branch_and_bound.h"

namespace rrr_graphslam::frontend {

/// A subset of mrpt::slam::CICP::TConfigParams with this use's defaults.
struct IcpRefinementParams {
  unsigned int max_iterations = 40;
  double threshold_dist_m = 0.3;  ///< initial correspondence distance
  double threshold_ang_rad = 0.15 * M_PI / 180;
  double alpha = 0.5;                       ///< thresholds shrink by this at each convergence
  double smallest_threshold_dist_m = 0.05;  ///< stop at this threshold (about one cell)
  /// MRPT's goodness (fraction of points with a correspondence) an alignment needs; below it
  /// the initial pose is kept.
  double min_goodness = 0.5;
};

/// The refined pose of a scan (points in the robot frame) in the grid's frame, or nullopt when
/// ICP finds too few correspondences.
std::optional<core::Pose2> refineIcp(const mrpt::maps::COccupancyGridMap2D& grid,
                                     const core::Pose2& initial, const PointCloud& points,
                                     const IcpRefinementParams& params);

}  // namespace rrr_graphslam::frontend
