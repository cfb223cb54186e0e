#pragma once
// Checks of one relative-pose constraint before it enters a graph, shared by the file readers
// and the online interfaces. Each returns an empty string when the value is fine, otherwise what
// is wrong with it, for the caller to prefix with where the value came from (file:line, or
// topic and field).

#include <string>

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::core {

/// Non-finite entries of a pose (x, y, theta).
std::string poseProblem(const Pose2& pose);

/// Non-finite entries, asymmetry beyond rounding, or not positive definite (with eigenvalues).
std::string informationProblem(const Eigen::Matrix3d& information);

}  // namespace rrr_graphslam::core
