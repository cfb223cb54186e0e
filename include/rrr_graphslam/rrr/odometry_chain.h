#pragma once
// The trusted odometry of a pose graph as chains of consecutive nodes ("sessions"), answering in
// O(1) the relative pose between any two nodes of a session and the information matrix of that
// compounded measurement. RRR's intra-cluster test uses it to replace the odometry between the
// nodes a cluster touches by one constraint each, instead of optimizing the whole chain.
//
// Covariances are propagated to first order in the g2o error convention (noise on the right):
// with P_k the chain poses from the session start and S_k = sum_{m<k} Ad(P_{m+1}) Sigma_m
// Ad(P_{m+1})^T (world-frame prefix sums), the measurement a -> b is P_a^-1 P_b with covariance
// Ad(P_b^-1) (S_b - S_a) Ad(P_b^-1)^T. test/rrr/test_odometry_chain.cpp checks it against the
// step-by-step recursion.

#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::rrr {

class OdometryChain {
 public:
  /// One odometry constraint between dense node indices, as stored in the graph.
  struct Link {
    int from;
    int to;
    core::Pose2 measurement;
    Eigen::Matrix3d information;
  };

  /// One step k -> k+1 in forward form.
  struct Step {
    core::Pose2 z;
    Eigen::Matrix3d information;
  };

  OdometryChain() = default;
  /// Links must join consecutive indices (k -> k+1 or k+1 -> k); several links between the same
  /// pair are fused. Throws std::invalid_argument naming the first link that is not consecutive.
  OdometryChain(int num_nodes, const std::vector<Link>& links);

  /// Online growth: a new node, starting a session until linkNewestNode() joins it to the one
  /// before. Returns its index.
  int appendNode();
  /// Odometry between the newest node and the one before (either direction); a second link for
  /// the same pair is fused with the first. Throws std::invalid_argument for any other pair.
  void linkNewestNode(const Link& link);

  int numNodes() const { return static_cast<int>(session_.size()); }
  /// Sessions are numbered 0, 1, ... in node order; a session is a maximal chain.
  int session(int node) const { return session_[static_cast<std::size_t>(node)]; }
  int numSessions() const { return num_sessions_; }
  bool sameSession(int a, int b) const { return session(a) == session(b); }
  /// First node of the session `node` belongs to.
  int sessionStart(int node) const { return session_start_[static_cast<std::size_t>(node)]; }

  /// Pose of `node` in the frame of its session's first node, by composing odometry.
  const core::Pose2& chainPose(int node) const { return pose_[static_cast<std::size_t>(node)]; }
  /// Path length (m) from the session's first node to `node`, along the odometry.
  double travel(int node) const { return travel_[static_cast<std::size_t>(node)]; }
  /// Odometry-composed pose of b in a's frame (same session, either order).
  core::Pose2 relativePose(int a, int b) const;
  /// Covariance of relativePose(a, b), a != b, same session.
  Eigen::Matrix3d relativeCovariance(int a, int b) const;
  /// S_node, the prefix sum above: the odometry noise between two nodes a < b of a session, moved
  /// to the session's frame, has covariance S_b - S_a, and two such ranges are correlated through
  /// the steps they share (pairwise_consistency.h uses that).
  const Eigen::Matrix3d& prefixCovariance(int node) const {
    return world_covariance_[static_cast<std::size_t>(node)];
  }

 private:
  /// Appends node numNodes(), continuing the previous session with `step` or starting one.
  void append(const Step* step);

  std::vector<int> session_;
  std::vector<Step> last_steps_;  // steps into each node (unused for session starts)
  std::vector<int> session_start_;
  int num_sessions_ = 0;
  std::vector<core::Pose2> pose_;                  // chain poses from the session start
  std::vector<Eigen::Matrix3d> world_covariance_;  // S_k, restarting at each session
  std::vector<double> travel_;                     // path length from the session start
};

}  // namespace rrr_graphslam::rrr
