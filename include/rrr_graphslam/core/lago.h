#pragma once
// Linear initialization of a 2D pose graph (LAGO: Carlone, Aragues, Castellanos, Bona, "A fast
// and accurate approximation for planar pose graph optimization", IJRR 2014): orientations by
// linear least squares on relative angles (each measured angle unwrapped against the current
// estimate, unwrapped along node order), then positions by linear least squares given those
// orientations. Far from the minimum (long drifted loops with tight angular information, e.g.
// KITTI) Gauss-Newton started there reaches the global minimum where one started from odometry
// stalls in a local one.

#include <vector>

#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {

/// Poses for the optimizer's active constraints (weights ignored) and dense factors (each
/// residual block a relative pose from the factor's root, weighted by its own block of the
/// information), starting from its current
/// poses for the angle unwrapping and for nodes no active constraint reaches. The optimizer's
/// gauge keeps its poses: its fixed nodes, or node 0 when none is fixed. Both linear solves go
/// through CHOLMOD.
std::vector<Pose2> lagoInitialization(const Optimizer& optimizer);

/// True when the optimizer's poses are far from a minimum: chi2 per active constraint (a dense
/// factor counts as its residual blocks) above
/// `chi2_per_constraint` (near a minimum it is about 3, the dimension of a constraint). Started
/// there, Gauss-Newton spends several factorizations on what LAGO's two linear solves give
/// (M3500 from its file's estimate: 458 per constraint, 6 iterations; from LAGO: 3).
bool farFromMinimum(const Optimizer& optimizer, double chi2_per_constraint = 100.0);

}  // namespace rrr_graphslam::core
