#include "rrr_graphslam/core/constraint_check.h"

#include <cmath>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace rrr_graphslam::core {
namespace {

const char* const kAxis[3] = {"x", "y", "theta"};

}  // namespace

std::string poseProblem(const Pose2& pose) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(pose[k])) return std::string(kAxis[k]) + " is not finite";
  }
  return {};
}

std::string informationProblem(const Eigen::Matrix3d& information) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(information(r, c))) {
        return "entry (" + std::to_string(r) + "," + std::to_string(c) + ") is not finite";
      }
    }
  }
  const double scale = information.cwiseAbs().maxCoeff();
  if ((information - information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return "the matrix is not symmetric";
  }
  if (Eigen::LLT<Eigen::Matrix3d>(information).info() != Eigen::Success) {
    std::ostringstream what;
    what << "the matrix is not positive definite (eigenvalues "
         << Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(information).eigenvalues().transpose()
         << ")";
    return what.str();
  }
  return {};
}

}  // namespace rrr_graphslam::core
