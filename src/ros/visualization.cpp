#include "rrr_graphslam/ros/visualization.h"

#include "rrr_graphslam/ros/conversions.h"

namespace rrr_graphslam::ros_adapter {
namespace {

visualization_msgs::Marker lineList(const std::string& ns, const std::string& frame,
                                    const ros::Time& stamp, float r, float g, float b,
                                    double width) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = 0;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.color.r = r;
  m.color.g = g;
  m.color.b = b;
  m.color.a = 1.0f;
  return m;
}

// Each session's path in a colour of its own (the first grey, as a map's usually is).
std_msgs::ColorRGBA sessionColour(int session) {
  static constexpr float kPalette[][3] = {{0.6f, 0.6f, 0.6f}, {0.0f, 0.6f, 0.9f},
                                          {0.9f, 0.5f, 0.0f}, {0.6f, 0.2f, 0.8f},
                                          {0.0f, 0.7f, 0.5f}, {0.8f, 0.3f, 0.5f}};
  constexpr int kColours = static_cast<int>(sizeof kPalette / sizeof kPalette[0]);
  const float* c = kPalette[session % kColours];
  std_msgs::ColorRGBA colour;
  colour.r = c[0];
  colour.g = c[1];
  colour.b = c[2];
  colour.a = 1.0f;
  return colour;
}

geometry_msgs::Point point(const core::Pose2& p) {
  geometry_msgs::Point q;
  q.x = p[0];
  q.y = p[1];
  return q;
}

}  // namespace

visualization_msgs::MarkerArray buildMarkers(const rrr::OnlineRrr& graph,
                                             const std::vector<core::Pose2>& map_poses,
                                             const std::string& frame, const ros::Time& stamp) {
  visualization_msgs::Marker odometry = lineList("odometry", frame, stamp, 0.6f, 0.6f, 0.6f, 0.05);
  visualization_msgs::Marker accepted =
      lineList("loops_accepted", frame, stamp, 0.1f, 0.8f, 0.1f, 0.08);
  visualization_msgs::Marker rejected =
      lineList("loops_rejected", frame, stamp, 0.9f, 0.1f, 0.1f, 0.04);
  visualization_msgs::Marker pending =
      lineList("loops_pending", frame, stamp, 1.0f, 0.85f, 0.0f, 0.06);
  visualization_msgs::Marker marginal = lineList("marginal", frame, stamp, 0.6f, 0.2f, 0.8f, 0.05);
  visualization_msgs::Marker dense = lineList("dense", frame, stamp, 0.9f, 0.5f, 0.1f, 0.03);
  visualization_msgs::Marker nodes = lineList("nodes", frame, stamp, 0.2f, 0.4f, 1.0f, 0.12);
  nodes.type = visualization_msgs::Marker::POINTS;
  nodes.scale.y = nodes.scale.x;

  int session = 0;
  for (int k = 0; k < graph.numNodes(); ++k) {
    const core::Pose2& p = map_poses[static_cast<std::size_t>(k)];
    nodes.points.push_back(point(p));
    if (graph.odometryBefore(k)) {
      odometry.points.push_back(point(map_poses[static_cast<std::size_t>(k - 1)]));
      odometry.points.push_back(point(p));
      odometry.colors.insert(odometry.colors.end(), 2, sessionColour(session));
    } else if (k > 0) {
      ++session;  // a node without odometry from the one before starts a session
    }
  }
  for (int k = 0; k < graph.numCandidates(); ++k) {
    const rrr::LoopCandidate& c = graph.candidate(k);
    const rrr::Verdict v = graph.verdict(k);
    auto& m = v == rrr::Verdict::kAccepted   ? accepted
              : v == rrr::Verdict::kRejected ? rejected
                                             : pending;
    m.points.push_back(point(map_poses[static_cast<std::size_t>(c.from)]));
    m.points.push_back(point(map_poses[static_cast<std::size_t>(c.to)]));
  }
  for (const rrr::MarginalLink& m : graph.marginalLinks()) {
    marginal.points.push_back(point(map_poses[static_cast<std::size_t>(m.from)]));
    marginal.points.push_back(point(map_poses[static_cast<std::size_t>(m.to)]));
  }
  for (int f = 0; f < graph.numDenseFactors(); ++f) {  // a star from each factor's root
    const std::vector<int>& members = graph.denseFactorNodes(f);
    for (std::size_t i = 1; i < members.size(); ++i) {
      dense.points.push_back(point(map_poses[static_cast<std::size_t>(members.front())]));
      dense.points.push_back(point(map_poses[static_cast<std::size_t>(members[i])]));
    }
  }
  visualization_msgs::MarkerArray array;
  array.markers = {odometry, accepted, rejected, pending, marginal, dense, nodes};
  // rviz reports an empty line list as an error; an empty namespace is deleted instead.
  for (auto& m : array.markers) {
    if (m.points.empty()) m.action = visualization_msgs::Marker::DELETE;
  }
  return array;
}

nav_msgs::Path buildPath(const rrr::OnlineRrr& graph, const std::vector<core::Pose2>& map_poses,
                         const std::vector<ros::Time>& node_stamps, const std::string& frame,
                         const ros::Time& stamp) {
  nav_msgs::Path path;
  path.header.frame_id = frame;
  path.header.stamp = stamp;
  path.poses.resize(static_cast<std::size_t>(graph.numNodes()));
  for (std::size_t k = 0; k < path.poses.size(); ++k) {
    auto& pose = path.poses[k];
    pose.header.frame_id = frame;
    pose.header.stamp = k < node_stamps.size() ? node_stamps[k] : stamp;
    pose.header.seq = static_cast<std::uint32_t>(graph.nodeIds()[k]);
    pose.pose = toPoseMsg(map_poses[k]);
  }
  return path;
}

}  // namespace rrr_graphslam::ros_adapter
