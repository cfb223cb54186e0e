#pragma once
// Trajectory refinement, the last offline step: every scan's pose is matched once more, by local
// SLAM's least-squares refinement, against the final map (every node's scan at its optimized
// pose), starting from and pulled toward its optimized pose.
//
// Why: local SLAM matched each scan against a submap built from local poses that the global
// optimization later moved, and a scan that is not a node is carried rigidly by the newest node.
// The final map is the best-aligned picture of the world the run has; matching against it removes
// part of the local matching error (on ACES the relation error drops by about 4%, see README).
// The nodes' graph and the map stay as the optimization left them.

#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/match_grid.h"
#include "rrr_graphslam/frontend/scan_matcher.h"

namespace rrr_graphslam::frontend {

struct TrajectoryRefinementParams {
  /// Cell size of the map the scans are matched against; 0 turns refinement off. Default 0.04 m
  /// (finer than the submaps: the final map has seen every place from many nodes).
  double resolution_m = 0.04;
  /// The same cost as local SLAM's refinement; the prior is the optimized pose.
  LeastSquaresParams least_squares;
  /// Scans with fewer matching points keep their optimized pose. Default 20.
  int min_points = 20;
};

/// poses[k] refined against `map` with points[k] (robot frame); both vectors the same length.
/// Runs on all cores (scans are independent); the result does not depend on the thread count.
std::vector<core::Pose2> refineTrajectory(const MatchGrid& map,
                                          const std::vector<PointCloud>& points,
                                          const std::vector<core::Pose2>& poses,
                                          const TrajectoryRefinementParams& params);

}  // namespace rrr_graphslam::frontend
