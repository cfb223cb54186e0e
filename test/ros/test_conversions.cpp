// Every message <-> core conversion of the ROS adapter: loop candidates and edges, odometry,
// laser scans, decisions, markers, the path and the occupancy grid; angles near +-pi included.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <mrpt/maps/COccupancyGridMap2D.h>
#include <tf2/LinearMath/Quaternion.h>

#include "rrr_graphslam/ros/conversions.h"
#include "rrr_graphslam/ros/visualization.h"

namespace rrr_graphslam::ros_adapter {
namespace {

const double kNearPi = M_PI - 1e-9;

geometry_msgs::Pose poseWithYaw(double yaw) {
  geometry_msgs::Pose p;
  p.position.x = 1.5;
  p.position.y = -2.0;
  tf2::Quaternion q;
  q.setRPY(0.0, 0.0, yaw);
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

double angleDifference(double a, double b) { return std::abs(core::normalizeAngle(a - b)); }

TEST(Conversions, CandidateAndEdgeFields) {
  geometry_msgs::Pose2D z;
  z.x = 1.0;
  z.y = -0.5;
  z.theta = -kNearPi;
  EXPECT_EQ(toPose2(z), core::Pose2(1.0, -0.5, -kNearPi));
  // information: row-major, so (0, 1) is the second entry.
  const boost::array<double, 9> info{{1, 2, 3, 4, 5, 6, 7, 8, 9}};
  const Eigen::Matrix3d m = toInformation(info);
  EXPECT_EQ(m(0, 1), 2.0);
  EXPECT_EQ(m(1, 0), 4.0);
  EXPECT_EQ(m(2, 1), 8.0);
}

TEST(Conversions, OdometryPoseYawAcrossPi) {
  for (const double yaw : {0.0, 1.0, kNearPi, -kNearPi, M_PI, -M_PI / 2}) {
    const core::Pose2 p = toPose2(poseWithYaw(yaw));
    EXPECT_DOUBLE_EQ(p.x(), 1.5);
    EXPECT_DOUBLE_EQ(p.y(), -2.0);
    EXPECT_LT(angleDifference(p.z(), yaw), 1e-9) << yaw;
    // And back through the message types the node publishes.
    EXPECT_LT(angleDifference(toPose2(toPoseMsg(p)).z(), yaw), 1e-9) << yaw;
    EXPECT_LT(angleDifference(toPose2(toTransformMsg(p)).z(), yaw), 1e-9) << yaw;
  }
}

TEST(Conversions, OdometryRefusesBadPosesNamingTheField) {
  geometry_msgs::Pose p = poseWithYaw(0.3);
  p.orientation.w *= 2.0;
  try {
    toPose2(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("orientation", 0), 0u) << e.what();
  }
  p = poseWithYaw(0.3);
  p.position.y = std::nan("");
  try {
    toPose2(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("position", 0), 0u) << e.what();
  }
}

TEST(Conversions, PlanarCovarianceTakesXYYaw) {
  boost::array<double, 36> c{};
  for (std::size_t k = 0; k < 36; ++k) c[k] = static_cast<double>(k);
  const auto m = planarCovariance(c);
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ((*m)(0, 0), 0.0);   // (x, x)
  EXPECT_EQ((*m)(0, 2), 5.0);   // (x, yaw)
  EXPECT_EQ((*m)(2, 1), 31.0);  // (yaw, y)
  EXPECT_EQ((*m)(2, 2), 35.0);  // (yaw, yaw)
  EXPECT_FALSE(planarCovariance(boost::array<double, 36>{}).has_value());
}

sensor_msgs::LaserScan scanMsg() {
  sensor_msgs::LaserScan s;
  s.header.stamp = ros::Time(12.5);
  s.angle_min = -kNearPi;
  s.angle_increment = 0.5;
  s.range_min = 0.1F;
  s.range_max = 10.0F;
  s.ranges = {1.0F, std::nanf(""), 0.05F, 20.0F, std::numeric_limits<float>::infinity()};
  s.angle_max = static_cast<float>(s.angle_min + 4 * s.angle_increment);
  return s;
}

TEST(Conversions, LaserScanReadings) {
  const frontend::RangeScan scan = toRangeScan(scanMsg(), core::Pose2(0.2, 0.0, M_PI));
  EXPECT_DOUBLE_EQ(scan.timestamp, 12.5);
  EXPECT_DOUBLE_EQ(scan.angle_min, static_cast<float>(-kNearPi));  // the message's float32
  EXPECT_EQ(scan.laser_in_robot, core::Pose2(0.2, 0.0, M_PI));
  ASSERT_EQ(scan.ranges.size(), 5u);
  EXPECT_EQ(scan.ranges[0], 1.0F);
  EXPECT_TRUE(std::isinf(scan.ranges[1]));  // NaN: a miss
  EXPECT_EQ(scan.ranges[2], 0.0F);          // below range_min: dropped
  EXPECT_EQ(scan.ranges[3], 20.0F);         // above range_max: the front end's miss
  EXPECT_TRUE(std::isinf(scan.ranges[4]));
}

TEST(Conversions, LaserScanRefusesBadHeadersNamingTheField) {
  auto refuses = [](sensor_msgs::LaserScan s, const std::string& field) {
    try {
      toRangeScan(s, core::Pose2::Zero());
      ADD_FAILURE() << field << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(field, 0), 0u) << e.what();
    }
  };
  sensor_msgs::LaserScan s = scanMsg();
  s.ranges.resize(1);
  refuses(s, "ranges");
  s = scanMsg();
  s.angle_increment = 0.0F;
  refuses(s, "angle_increment");
  s = scanMsg();
  s.range_max = std::nanf("");
  refuses(s, "range_max");
  s = scanMsg();
  s.angle_min = std::numeric_limits<float>::infinity();
  refuses(s, "angle_min");
  // The readings must fill angle_min..angle_max (one more or less at the end is accepted).
  s = scanMsg();
  s.ranges.resize(17, 1.0F);
  refuses(s, "ranges holds 17 readings, but angle_min");
  s = scanMsg();
  s.angle_max = std::nanf("");
  refuses(s, "ranges holds 5 readings");
  s = scanMsg();
  s.ranges.push_back(1.0F);
  EXPECT_NO_THROW(toRangeScan(s, core::Pose2::Zero()));
}

TEST(Conversions, DecisionFieldsAndIdsTheMessageCannotCarry) {
  rrr::DecisionChange change{7,
                             4000000000ULL,
                             12,
                             3,
                             rrr::Verdict::kRejected,
                             rrr::Verdict::kAccepted,
                             "reverse: CI 2 >= 1"};
  const LoopClosureDecision msg = toDecisionMsg(change, "map", ros::Time(3.0));
  EXPECT_EQ(msg.candidate, 7u);
  EXPECT_EQ(msg.from_id, 4000000000u);
  EXPECT_EQ(msg.to_id, 12u);
  EXPECT_EQ(msg.cluster, 3);
  EXPECT_EQ(msg.verdict, LoopClosureDecision::REJECTED);
  EXPECT_EQ(msg.previous_verdict, LoopClosureDecision::ACCEPTED);
  EXPECT_EQ(msg.reason, "reverse: CI 2 >= 1");
  EXPECT_EQ(msg.header.frame_id, "map");
  EXPECT_EQ(toVerdictMsg(rrr::Verdict::kPending), LoopClosureDecision::PENDING);
  change.from = (1ULL << 32) + 9;
  try {
    toDecisionMsg(change, "map", ros::Time(3.0));
    FAIL() << "2^32 + 9 truncated";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("from_id 4294967305", 0), 0u) << e.what();
  }
}

// A robot on a 10 m x 10 m square, one node per metre, two laps: one true loop candidate and
// one false one.
TEST(Conversions, MarkersAndPathShowTheGraph) {
  rrr::OnlineRrr graph;
  const Eigen::Matrix3d info = Eigen::Vector3d(100, 100, 1000).asDiagonal();
  auto pose = [](int k) {
    const int lap = k % 40, side = lap / 10;
    const core::Pose2 corners[4] = {
        {0, 0, 0}, {10, 0, M_PI / 2}, {10, 10, M_PI}, {0, 10, -M_PI / 2}};
    return core::compose(corners[side], core::Pose2(lap % 10, 0, 0));
  };
  graph.startSession(0, pose(0));
  for (int k = 1; k < 60; ++k)
    graph.addOdometry(k - 1, k, core::between(pose(k - 1), pose(k)), info);
  graph.addCandidate(40, 0, core::between(pose(40), pose(0)), info);
  graph.addCandidate(45, 25, core::Pose2(0, 0, 0), info);            // 10 m apart, said to coincide
  graph.addMarginal(5, 35, core::between(pose(5), pose(35)), info);  // as a trim would leave it
  core::DenseFactor dense;  // as a dense trim would leave it: 12 -> 31, 12 -> 50
  dense.nodes = {12, 31, 50};
  dense.measurements = {core::between(pose(12), pose(31)), core::between(pose(12), pose(50))};
  dense.mean = Eigen::VectorXd::Zero(6);
  dense.information = 100.0 * Eigen::MatrixXd::Identity(6, 6);
  graph.addDenseFactor(dense);
  EXPECT_EQ(graph.status().dense_factors, 1);
  graph.finish();
  const std::vector<core::Pose2> poses = graph.mapPoses();
  const visualization_msgs::MarkerArray markers = buildMarkers(graph, poses, "map", ros::Time(1));
  ASSERT_EQ(markers.markers.size(), 7u);
  std::map<std::string, const visualization_msgs::Marker*> by_ns;
  for (const auto& m : markers.markers) {
    by_ns[m.ns] = &m;
    EXPECT_EQ(m.header.frame_id, "map");
  }
  EXPECT_EQ(by_ns.at("odometry")->points.size(), 2u * 59);
  EXPECT_EQ(by_ns.at("nodes")->points.size(), 60u);
  EXPECT_EQ(by_ns.at("loops_accepted")->points.size(), 2u);
  EXPECT_EQ(by_ns.at("loops_rejected")->points.size(), 2u);
  EXPECT_EQ(by_ns.at("loops_pending")->action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(by_ns.at("marginal")->points.size(), 2u);
  EXPECT_EQ(by_ns.at("dense")->points.size(), 4u);
  // The accepted loop's ends meet in the map.
  const auto& a = by_ns.at("loops_accepted")->points;
  EXPECT_LT(std::hypot(a[0].x - a[1].x, a[0].y - a[1].y), 0.05);

  const nav_msgs::Path path = buildPath(graph, poses, {}, "map", ros::Time(2));
  ASSERT_EQ(path.poses.size(), 60u);
  for (std::size_t k = 0; k < path.poses.size(); ++k) {
    EXPECT_EQ(path.poses[k].header.seq, k);
    EXPECT_LT(angleDifference(toPose2(path.poses[k].pose).z(), poses[k].z()), 1e-9) << k;
  }
}

TEST(Conversions, EachSessionsPathHasItsOwnColour) {
  rrr::OnlineRrr graph;
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity() * 100.0;
  graph.startSession(0, core::Pose2::Zero());
  for (rrr::OnlineRrr::NodeId k = 1; k < 4; ++k) graph.addOdometry(k - 1, k, {1, 0, 0}, info);
  graph.startSession(10, core::Pose2(5, 5, 0));
  for (rrr::OnlineRrr::NodeId k = 11; k < 13; ++k) graph.addOdometry(k - 1, k, {1, 0, 0}, info);
  const auto markers = buildMarkers(graph, graph.mapPoses(), "map", ros::Time(1));
  const visualization_msgs::Marker& odometry = markers.markers.front();
  ASSERT_EQ(odometry.ns, "odometry");
  ASSERT_EQ(odometry.points.size(), 2u * (3 + 2));
  ASSERT_EQ(odometry.colors.size(), odometry.points.size());
  const auto& first = odometry.colors.front();
  const auto& second = odometry.colors.back();
  EXPECT_EQ(odometry.colors[5].b, first.b);  // session 0's three edges: one colour
  EXPECT_TRUE(first.r != second.r || first.g != second.g || first.b != second.b);
}

TEST(Conversions, OccupancyGridCells) {
  mrpt::maps::COccupancyGridMap2D grid(-1.0F, 1.0F, -0.5F, 0.5F, 0.1F);
  grid.setCell(0, 0, 0.9F);   // free with p = 0.9
  grid.setCell(19, 9, 0.1F);  // occupied
  nav_msgs::OccupancyGrid msg;
  toOccupancyGridMsg(grid, msg);
  EXPECT_EQ(msg.info.width, grid.getSizeX());
  EXPECT_EQ(msg.info.height, grid.getSizeY());
  EXPECT_NEAR(msg.info.origin.position.x, -1.0, 1e-6);
  EXPECT_NEAR(msg.info.resolution, 0.1, 1e-6);
  ASSERT_EQ(msg.data.size(), static_cast<std::size_t>(msg.info.width * msg.info.height));
  EXPECT_NEAR(msg.data[0], 10, 1);
  EXPECT_NEAR(msg.data[9 * msg.info.width + 19], 90, 1);
  EXPECT_EQ(msg.data[5 * msg.info.width + 5], -1);  // never observed
}

}  // namespace
}  // namespace rrr_graphslam::ros_adapter
