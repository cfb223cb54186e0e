#include "rrr_graphslam/rrr/odometry_chain.h"

#include <Eigen/Dense>
#include <optional>
#include <stdexcept>
#include <string>

namespace rrr_graphslam::rrr {
namespace {

using core::Pose2;

using Step = OdometryChain::Step;

// Step k -> k+1 from a link in either direction.
Step forwardStep(const OdometryChain::Link& link) {
  if (link.to == link.from + 1) return {link.measurement, link.information};
  return {core::inverse(link.measurement),
          core::informationOfInverse(link.measurement, link.information)};
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
  for (std::size_t k = 0; k < n; ++k) append(k > 0 && steps[k - 1] ? &*steps[k - 1] : nullptr);
}

int OdometryChain::appendNode() {
  append(nullptr);
  return numNodes() - 1;
}

void OdometryChain::linkNewestNode(const Link& link) {
  const int newest = numNodes() - 1;
  if (newest < 1 || std::max(link.from, link.to) != newest ||
      std::min(link.from, link.to) != newest - 1) {
    throw std::invalid_argument("odometry " + std::to_string(link.from) + " -> " +
                                std::to_string(link.to) + " does not join the newest node " +
                                std::to_string(newest) + " to the one before");
  }
  const Step s = forwardStep(link);
  const bool linked =
      session_[static_cast<std::size_t>(newest)] == session_[static_cast<std::size_t>(newest - 1)];
  const Step step = linked ? fuse(last_steps_.back(), s) : s;
  if (!linked) --num_sessions_;
  session_.pop_back();
  session_start_.pop_back();
  pose_.pop_back();
  world_covariance_.pop_back();
  last_steps_.pop_back();
  travel_.pop_back();
  append(&step);
}

void OdometryChain::append(const Step* step) {
  const std::size_t k = session_.size();
  if (step == nullptr) {
    session_.push_back(num_sessions_++);
    session_start_.push_back(static_cast<int>(k));
    pose_.push_back(Pose2::Zero());
    world_covariance_.push_back(Eigen::Matrix3d::Zero());
    last_steps_.push_back(Step{Pose2::Zero(), Eigen::Matrix3d::Identity()});
    travel_.push_back(0.0);
    return;
  }
  session_.push_back(session_[k - 1]);
  session_start_.push_back(session_start_[k - 1]);
  pose_.push_back(core::compose(pose_[k - 1], step->z));
  const Eigen::Matrix3d Ad = core::adjoint(pose_[k]);
  world_covariance_.push_back(world_covariance_[k - 1] +
                              Ad * step->information.inverse() * Ad.transpose());
  last_steps_.push_back(*step);
  travel_.push_back(travel_[k - 1] + step->z.head<2>().norm());
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
