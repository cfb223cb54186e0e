#include "rrr_graphslam/rrr/odometry_chain.h"

#include <Eigen/Dense>
#include <optional>
#include <stdexcept>
#include <string>

namespace rrr_graphslam::rrr {
namespace {

using core::Pose2;

struct Step {
  Pose2 z;
  Eigen::Matrix3d information;
};

// Step k -> k+1 from a link in either direction. Reversing z (noise on the right) maps the
// covariance through Ad(z): z^-1 with right noise -Ad(z) eta.
Step forwardStep(const OdometryChain::Link& link) {
  if (link.to == link.from + 1) return {link.measurement, link.information};
  const Eigen::Matrix3d Ad = core::adjoint(link.measurement);
  const Eigen::Matrix3d Ad_inv = Ad.inverse();
  return {core::inverse(link.measurement), Ad_inv.transpose() * link.information * Ad_inv};
}

// Two measurements of the same step, fused in the tangent space at the first.
Step fuse(const Step& a, const Step& b) {
  Eigen::Vector3d d = core::between(a.z, b.z);
  const Eigen::Matrix3d information = a.information + b.information;
  const Eigen::Vector3d mean = information.ldlt().solve(b.information * d);
  return {core::compose(a.z, mean), information};
}

}  // namespace

OdometryChain::OdometryChain(int num_nodes, const std::vector<Link>& links) {
  const auto n = static_cast<std::size_t>(num_nodes);
  std::vector<std::optional<Step>> steps(n);
  for (const Link& link : links) {
    const int low = std::min(link.from, link.to);
    if (std::abs(link.to - link.from) != 1 || low < 0 || low + 1 >= num_nodes) {
      throw std::invalid_argument("odometry edge " + std::to_string(link.from) + " -> " +
                                  std::to_string(link.to) + " does not join consecutive nodes");
    }
    const Step s = forwardStep(link);
    auto& slot = steps[static_cast<std::size_t>(low)];
    slot = slot ? fuse(*slot, s) : s;
  }

  session_.resize(n);
  session_start_.resize(n);
  pose_.resize(n);
  world_covariance_.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const bool starts_session = k == 0 || !steps[k - 1];
    if (starts_session) {
      session_[k] = num_sessions_++;
      session_start_[k] = static_cast<int>(k);
      pose_[k] = Pose2::Zero();
      world_covariance_[k].setZero();
      continue;
    }
    const Step& s = *steps[k - 1];
    session_[k] = session_[k - 1];
    session_start_[k] = session_start_[k - 1];
    pose_[k] = core::compose(pose_[k - 1], s.z);
    const Eigen::Matrix3d Ad = core::adjoint(pose_[k]);
    world_covariance_[k] = world_covariance_[k - 1] + Ad * s.information.inverse() * Ad.transpose();
  }
}

Pose2 OdometryChain::relativePose(int a, int b) const {
  return core::between(chainPose(a), chainPose(b));
}

Eigen::Matrix3d OdometryChain::relativeCovariance(int a, int b) const {
  const Eigen::Matrix3d Ad_b_inv = core::adjoint(core::inverse(chainPose(b)));
  Eigen::Matrix3d sum = world_covariance_[static_cast<std::size_t>(std::max(a, b))] -
                        world_covariance_[static_cast<std::size_t>(std::min(a, b))];
  // For b < a the noise of the steps between them enters with the opposite sign: same covariance.
  sum = 0.5 * (sum + sum.transpose());
  return Ad_b_inv * sum * Ad_b_inv.transpose();
}

}  // namespace rrr_graphslam::rrr
