// Slam mode's input: scans released in arrival order once their transforms are known (at most
// tf_timeout), the relocalization hint from /initialpose, and the front end they feed.

#include <chrono>
#include <stdexcept>

#include "rrr_graphslam/ros/conversions.h"
#include "rrr_graphslam/ros/graph_slam_ros.h"
#include "topics.h"

namespace rrr_graphslam::ros_adapter {
namespace {

// Seconds on a clock that never steps (the wall clock may: NTP), for how long a scan has waited.
double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

void GraphSlamRos::scanCallback(const sensor_msgs::LaserScanConstPtr& msg) {
  try {
    // The filter let the scan through: both transforms are known at its stamp.
    const ros::Duration timeout(params_.tf_timeout);
    const auto odom = tf_buffer_->lookupTransform(params_.odom_frame, params_.base_frame,
                                                  msg->header.stamp, timeout);
    const auto laser = tf_buffer_->lookupTransform(params_.base_frame, msg->header.frame_id,
                                                   msg->header.stamp, timeout);
    scanSettled(msg.get(), ScanInput{msg, toPose2(odom.transform), toPose2(laser.transform)});
  } catch (const std::exception& e) {  // tf2::TransformException, or a bad transform
    dropScan(*msg, e.what());
  }
}

void GraphSlamRos::scanArrived(const sensor_msgs::LaserScanConstPtr& msg) {
  std::lock_guard<std::mutex> lock(scan_order_mutex_);
  scan_order_.arrived(msg.get(), steadySeconds());
}

bool GraphSlamRos::scanSettled(const sensor_msgs::LaserScan* msg, std::optional<ScanInput> input) {
  std::lock_guard<std::mutex> lock(scan_order_mutex_);
  if (!scan_order_.settle(msg, std::move(input))) return false;
  for (ScanInput& ready : scan_order_.release()) enqueue(std::move(ready), kScanTopic);
  return true;
}

void GraphSlamRos::expireScans(const ros::WallTimerEvent&) {
  std::vector<std::pair<const sensor_msgs::LaserScan*, double>> expired;
  {
    std::lock_guard<std::mutex> lock(scan_order_mutex_);
    expired = scan_order_.expire(steadySeconds(), params_.tf_timeout);
    for (ScanInput& ready : scan_order_.release()) enqueue(std::move(ready), kScanTopic);
  }
  for (const auto& [msg, arrival] : expired) {
    (void)arrival;
    ++received_;
    ++malformed_;
    ++processed_;
    // The scan may be gone already (its pointer is only a key): nothing of it is read here.
    logInputError(kScanTopic, "scan dropped: its transforms " + params_.odom_frame + " -> " +
                                  params_.base_frame +
                                  " -> header.frame_id did not arrive "
                                  "within tf_timeout (" +
                                  std::to_string(params_.tf_timeout) +
                                  " s; unknown frame, or a stamp ahead of tf)");
  }
}

void GraphSlamRos::dropScan(const sensor_msgs::LaserScan& msg, const std::string& why) {
  if (!scanSettled(&msg, std::nullopt)) return;  // given up already, and counted then
  ++received_;
  ++malformed_;
  ++processed_;
  logInputError(kScanTopic, "header.frame_id '" + msg.header.frame_id + "' at header.stamp " +
                                std::to_string(msg.header.stamp.toSec()) +
                                ": scan dropped, no usable transform " + params_.odom_frame +
                                " -> " + params_.base_frame + " -> scan: " + why);
}

void GraphSlamRos::initialPose(const geometry_msgs::PoseWithCovarianceStamped& msg) {
  ++received_;
  core::Pose2 pose;
  try {
    if (msg.header.frame_id != params_.map_frame) {
      throw std::invalid_argument("header.frame_id '" + msg.header.frame_id + "' is not " +
                                  params_.map_frame);
    }
    pose = toPose2(msg.pose.pose);
  } catch (const std::invalid_argument& e) {
    ++malformed_;
    ++processed_;
    logInputError(kInitialPoseTopic, std::string(e.what()) + "; message dropped");
    return;
  }
  ++processed_;
  enqueue(Command([this, pose] {
            try {
              if (trimmer_) trimmer_->drop();  // made before the hint: it would lose it
              slam_->setInitialPose(pose);
              ROS_INFO("%s: relocalizing around (%.2f, %.2f, %.2f) until the session is tied",
                       nh_.resolveName(kInitialPoseTopic).c_str(), pose.x(), pose.y(), pose.z());
            } catch (const std::logic_error& e) {
              ROS_WARN("%s: ignored: %s", nh_.resolveName(kInitialPoseTopic).c_str(), e.what());
            }
          }),
          kInitialPoseTopic);
}

void GraphSlamRos::handleScan(const ScanInput& input) {
  if (!claim(Owner::kScan, kScanTopic)) return;
  const sensor_msgs::LaserScan& msg = *input.msg;
  if (!last_scan_stamp_.isZero() && msg.header.stamp <= last_scan_stamp_) {
    throw std::invalid_argument("header.stamp " + std::to_string(msg.header.stamp.toSec()) +
                                " is not after the previous scan's " +
                                std::to_string(last_scan_stamp_.toSec()));
  }
  const frontend::RangeScan scan = toRangeScan(msg, input.laser_in_base);
  last_scan_stamp_ = msg.header.stamp;
  owner_ = Owner::kScan;
  std::optional<int> node;
  try {
    node = slam_->addScan(scan, input.odom);
  } catch (const frontend::ScanRefused&) {
    trimOnline(scan, input.odom, std::nullopt);  // a refused scan re-anchors the odometry
    throw;
  }
  if (node) {
    node_stamps_.push_back(msg.header.stamp);
    newest_node_odom_ = input.odom;
    dirty_ = true;
    map_dirty_ = true;
  }
  trimOnline(scan, input.odom, node);
}

void GraphSlamRos::trimOnline(const frontend::RangeScan& scan, const core::Pose2& odom,
                              std::optional<int> node) {
  if (trimmer_) adoptTrimmed([&] { return trimmer_->afterScan(*slam_, scan, odom, node); });
}

void GraphSlamRos::pollOnlineTrim() {
  if (trimmer_ && slam_ && adoptTrimmed([&] { return trimmer_->poll(); })) {
    publishChanges();  // the trimmed map's verdicts, renumbered
  }
}

bool GraphSlamRos::adoptTrimmed(
    const std::function<std::unique_ptr<frontend::LaserSlam>()>& harvest) {
  std::unique_ptr<frontend::LaserSlam> trimmed;
  try {
    trimmed = harvest();
  } catch (const std::exception& e) {  // what the trim threw: the map goes on untrimmed
    ROS_ERROR("lifelong: online trim failed, the map goes on as it was: %s", e.what());
    return false;
  }
  if (!trimmed) return false;
  // Renumbered after the removed nodes: the stamps follow (the newest node, whose odometry pose
  // makes map -> odom, always stays).
  std::vector<ros::Time> stamps;
  for (double t : trimmed->nodeTimestamps()) stamps.emplace_back(t);
  slam_ = std::move(trimmed);
  slam_->rrr().setCancelFlag(&cancel_);
  node_stamps_ = std::move(stamps);
  dirty_ = true;
  map_dirty_ = true;
  const frontend::OnlineTrimRecord& r = *trimmer_->last();
  ROS_INFO(
      "lifelong: trimmed %d submaps while mapping, %d -> %d nodes (%d "
      "marginal edges) in %.0f ms off the mapping thread; %d scans replayed in %.0f ms",
      r.report.trimmed_submaps, r.nodes_before, r.nodes_after, r.report.marginalEdges(), r.trim_ms,
      r.replayed_scans, r.replay_ms);
  return true;
}

void GraphSlamRos::startSlam(const frontend::MapSnapshot* map) {
  frontend::LaserSlamParams p = params_.slam;
  p.rrr = params_.rrr;
  // Sessions are named by the node and the wall time they started at.
  const std::string name =
      private_nh_.getNamespace() + " " + std::to_string(ros::WallTime::now().toSec());
  // Built before anything is replaced: a map that cannot be continued leaves the running one.
  const frontend::SessionMode mode = params_.mode == "localization"
                                         ? frontend::SessionMode::kLocalization
                                         : frontend::SessionMode::kMapping;
  std::unique_ptr<frontend::LaserSlam> slam =
      map != nullptr ? frontend::LaserSlam::fromMap(*map, p, name, mode)
                     : std::make_unique<frontend::LaserSlam>(p, name);
  std::vector<ros::Time> stamps;
  for (double t : slam->nodeTimestamps()) {
    if (!(t >= 0.0 && t < 4294967295.0)) {
      throw std::invalid_argument("a node's timestamp " + std::to_string(t) +
                                  " is outside ROS time");
    }
    stamps.emplace_back(t);
  }
  // A fresh trimmer: a trim in flight trims the map being replaced, and ~status counts the new
  // map's trims.
  trimmer_.reset();
  if (params_.trim_every_n_nodes > 0) {
    trimmer_ = std::make_unique<frontend::OnlineTrimmer>(
        frontend::OnlineTrimParams{params_.trim, params_.trim_every_n_nodes, false});
  }
  slam_ = std::move(slam);
  slam_->rrr().setCancelFlag(&cancel_);
  sensor_mismatch_.clear();  // a new map: its scans' setup is checked anew
  sensor_mismatch_scans_ = 0;
  node_stamps_ = std::move(stamps);
  newest_node_odom_.reset();  // the current session has no node yet
  last_scan_stamp_ = ros::Time();
  map_dirty_ = true;
}

void GraphSlamRos::offerMap() {
  // Rendered on the map publisher's thread, and only for subscribers: until one comes, the map
  // stays dirty and is offered then (a latched map reaches later subscribers as well).
  if (!map_publisher_->wanted()) return;
  map_dirty_ = false;
  last_map_ = std::chrono::steady_clock::now();
  frontend::MapInputs inputs = slam_->mapInputs();
  inputs.layering = params_.map_layering;
  inputs.render = params_.map_render;
  map_publisher_->offer(std::move(inputs));
}

}  // namespace rrr_graphslam::ros_adapter
