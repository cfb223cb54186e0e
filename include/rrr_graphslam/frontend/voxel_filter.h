#pragma once
// Voxel filters for scan points: one point per voxel, and Cartographer's adaptive variant that
// finds the coarsest voxel (up to a limit) still leaving enough points. Branch-and-bound's cost
// grows with the points it scores, and a loop match needs the shape of the scan, not every
// point of it: the loop search thins each scan adaptively (Hess et al. 2016 use 0.9 m / 100).

#include "rrr_graphslam/frontend/branch_and_bound.h"

namespace rrr_graphslam::frontend {

/// The first point (in order) of each voxel of side `voxel_m`; order kept.
PointCloud voxelFilter(const PointCloud& points, double voxel_m);

/// voxelFilter with the largest voxel side in (0, max_voxel_m] that leaves at least min_points
/// points (found by bisection to within 10%); clouds of at most min_points points are returned
/// as they are.
PointCloud adaptiveVoxelFilter(const PointCloud& points, double max_voxel_m, int min_points);

}  // namespace rrr_graphslam::frontend
