#include "rrr_graphslam/frontend/icp_refinement.h"

#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPosePDF.h>
#include <mrpt/slam/CICP.h>

namespace rrr_graphslam::frontend {

std::optional<core::Pose2> refineIcp(const mrpt::maps::COccupancyGridMap2D& grid,
                                     const core::Pose2& initial, const PointCloud& points,
                                     const IcpRefinementParams& params) {
  mrpt::maps::CSimplePointsMap scan;
  scan.reserve(points.size());
  for (const auto& p : points) {
    scan.insertPoint(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0F);
  }
  mrpt::slam::CICP icp;
  icp.options.ICP_algorithm = mrpt::slam::icpClassic;
  icp.options.maxIterations = params.max_iterations;
  icp.options.thresholdDist = params.threshold_dist_m;
  icp.options.thresholdAng = params.threshold_ang_rad;
  icp.options.ALFA = params.alpha;
  icp.options.smallestThresholdDist = params.smallest_threshold_dist_m;
  icp.options.corresponding_points_decimation = 1;  // every point: scans are small
  icp.options.skip_cov_calculation = true;
  mrpt::slam::CICP::TReturnInfo info;
  const auto pdf =
      icp.Align(&grid, &scan, mrpt::poses::CPose2D(initial.x(), initial.y(), initial.z()), info);
  if (!pdf || info.goodness < params.min_goodness) return std::nullopt;
  const mrpt::poses::CPose2D mean = pdf->getMeanVal();
  return core::Pose2(mean.x(), mean.y(), core::normalizeAngle(mean.phi()));
}

}  // namespace rrr_graphslam::frontend
