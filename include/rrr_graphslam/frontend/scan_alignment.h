#pragma once
// Direct alignment of two raw scans, independent of any map: the relative pose of a revisit as
// the scans themselves see it, for checking a SLAM estimate against its own data
// (rrr_align_scans, scripts/evaluate_slam).
//
// 1. Branch-and-bound search (Hess et al. 2016; branch_and_bound.h) of the query scan's points on
//    a grid built from the reference scan's points alone (a cell holding a point scores 1, its
//    neighbours `neighbour_value`), in a window around the initial pose: wide enough to find a
//    revisit the estimate has metres wrong.
// 2. MRPT's point-to-point ICP (mrpt::slam::CICP, classic) between the two point sets from that
//    pose, which is not limited to the grid's cells.
// The result is scored by overlapFraction: the share of the query's points within a distance of
// a reference point, which also scores any other relative pose (an estimate's, a reference's).

#include <optional>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/branch_and_bound.h"

namespace rrr_graphslam::frontend {

struct ScanAlignmentParams {
  double resolution_m = 0.05;    ///< cell size of the search grid (default 0.05 m)
  double neighbour_value = 0.5;  ///< score of the 8 cells around a point's cell (default 0.5)
  /// Around the initial pose (default 2 m, 15 degrees).
  SearchWindow window{2.0, 15.0 * M_PI / 180};
  int branch_and_bound_depth = 6;  ///< levels of max-grids (default 6)
  /// Branch-and-bound score (mean cell value over the query's points) a match needs (default 0.3).
  double min_score = 0.3;
  unsigned int icp_max_iterations = 40;  ///< CICP iterations (default 40)
  double icp_threshold_dist_m = 0.3;     ///< CICP's initial correspondence distance (default 0.3 m)
  double icp_smallest_threshold_dist_m = 0.02;  ///< CICP stops at this threshold (default 0.02 m)
};

struct ScanAlignment {
  core::Pose2 pose;  ///< the query scan's pose in the reference scan's frame
  double score;      ///< the branch-and-bound score, in [0, 1]
};

/// The pose of `query` in the frame of `reference` (both point sets in their own robot frame),
/// searched around `initial`; nullopt when either is empty or nothing scores above min_score.
std::optional<ScanAlignment> alignScans(const PointCloud& reference, const PointCloud& query,
                                        const core::Pose2& initial,
                                        const ScanAlignmentParams& params);

/// Step 2 alone: MRPT's ICP from `initial` (the nearest local optimum); `initial` when ICP fails
/// or overlaps less than it within resolution_m.
core::Pose2 refineScanIcp(const PointCloud& reference, const PointCloud& query,
                          const core::Pose2& initial, const ScanAlignmentParams& params);

/// A scan's surfaces as points: `points` in beam order (as matchingPoints leaves them), with
/// points every `step_m` added between consecutive ones at most `max_gap_m` apart (a wall seen
/// with beams 1 degree apart has points 17 cm apart at 10 m: without them, a point of another
/// scan on that wall can lie more than 10 cm from every point).
PointCloud surfacePoints(const PointCloud& points, double max_gap_m, double step_m);

/// Share of `query`'s points that, placed at `query_pose` in the reference's frame, lie within
/// `distance_m` of a point of `reference`; 0 for an empty query.
double overlapFraction(const PointCloud& reference, const PointCloud& query,
                       const core::Pose2& query_pose, double distance_m);

}  // namespace rrr_graphslam::frontend
