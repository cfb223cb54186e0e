#pragma once
// The ROS adapter around rrr::OnlineRrr, shared by the nodelet and the standalone node.
//
// Callbacks only convert and queue; one worker thread owns the graph and runs RRR, so no callback
// ever waits for an optimization. Services (~save, ~load, ~reset, ~optimize, ~finish) are served
// on a callback queue of their own and executed by the worker in turn with the input.
//
// In (relative to the node handle, remap freely): odom (nav_msgs/Odometry), pose_graph_edges
// (PoseGraphEdge), loop_candidates (LoopCandidate); in slam mode (input_mode scan) scan
// (sensor_msgs/LaserScan) with tf odom_frame -> base_frame -> the scan's frame (a tf2 message
// filter holds each scan until its transforms are known).
// Out (private): ~decisions (LoopClosureDecision), ~markers (MarkerArray, latched, built only for
// subscribers), ~path (nav_msgs/Path, latched), ~status (RrrStatus), tf map -> odom; in slam mode
// also map (nav_msgs/OccupancyGrid, latched, relative to the node handle like map_server's;
// rendered on a thread of its own, only while it has subscribers, at most every
// map_publish_period, and again only when a node or a decision changed it).

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <message_filters/subscriber.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "rrr_graphslam/LoadGraph.h"
#include "rrr_graphslam/LoadMap.h"
#include "rrr_graphslam/LoopCandidate.h"
#include "rrr_graphslam/PoseGraphEdge.h"
#include "rrr_graphslam/SaveGraph.h"
#include "rrr_graphslam/SaveMap.h"
#include "rrr_graphslam/core/keyframe_selector.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/online_trimmer.h"
#include "rrr_graphslam/ros/arrival_order.h"
#include "rrr_graphslam/ros/input_error_log.h"
#include "rrr_graphslam/ros/map_publisher.h"
#include "rrr_graphslam/ros/params.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::ros_adapter {

class GraphSlamRos {
 public:
  /// Throws std::invalid_argument for invalid parameters (naming the parameter).
  GraphSlamRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~GraphSlamRos();
  GraphSlamRos(const GraphSlamRos&) = delete;
  GraphSlamRos& operator=(const GraphSlamRos&) = delete;

 private:
  enum class Owner { kNone, kOdometry, kEdges, kScan };
  using Command = std::function<void()>;
  /// A scan with the transforms looked up at its stamp (in the subscriber thread).
  struct ScanInput {
    sensor_msgs::LaserScanConstPtr msg;
    core::Pose2 odom;           ///< base_frame in odom_frame
    core::Pose2 laser_in_base;  ///< the scan's frame in base_frame
  };
  using Input = std::variant<nav_msgs::OdometryConstPtr, PoseGraphEdgeConstPtr,
                             LoopCandidateConstPtr, ScanInput, Command>;

  // Subscriber threads.
  void enqueue(Input input, const char* topic);
  void scanCallback(const sensor_msgs::LaserScanConstPtr& msg);
  void dropScan(const sensor_msgs::LaserScan& msg, const std::string& why);
  /// The tf filter releases scans when their transforms arrive, which can reorder them; scans go
  /// on to the worker in the order they arrived (a released or dropped scan waits for the ones
  /// that arrived before it, at most tf_timeout: see expireScans).
  void scanArrived(const sensor_msgs::LaserScanConstPtr& msg);
  /// False if the scan no longer waits (given up by expireScans): it is then neither forwarded
  /// nor counted again.
  bool scanSettled(const sensor_msgs::LaserScan* msg, std::optional<ScanInput> input);
  /// Gives up scans that waited for their transforms longer than tf_timeout (each counted and
  /// reported), so that the scans after them go on.
  void expireScans(const ros::WallTimerEvent&);
  /// Runs `job` in the worker and waits for it; false (with the reason) if it threw.
  bool runInWorker(const std::function<std::string()>& job, std::string& message);

  // Worker thread.
  void workerLoop();
  void process(const Input& input);
  void handleOdometry(const nav_msgs::Odometry& msg);
  /// Information of the odometry step from the last keyframe to `pose` (see core/odometry_noise.h).
  Eigen::Matrix3d stepInformation(const core::Pose2& pose,
                                  const std::optional<Eigen::Matrix3d>& covariance);
  void handleEdge(const PoseGraphEdge& msg);
  void handleCandidate(const LoopCandidate& msg);
  void handleScan(const ScanInput& input);
  /// /initialpose (slam mode): a relocalization hint for the current session (in the worker).
  void initialPose(const geometry_msgs::PoseWithCovarianceStamped& msg);
  /// Logs an error about `topic`'s input through input_errors_ (throttled, quoted short).
  void logInputError(const char* topic, const std::string& what);
  /// The graph RRR decides: the front end's in slam mode, else the node's own.
  rrr::OnlineRrr& graph() { return slam_ ? slam_->rrr() : *graph_; }
  /// Slam mode: a fresh front end (start, ~reset), or one continuing `map` in a new session
  /// (map_file, ~load_map).
  void startSlam(const frontend::MapSnapshot* map = nullptr);
  /// Slam mode: hands the scan to the online trimmer (trim_every_n_nodes), and adopts the
  /// trimmed map when a trim has finished.
  void trimOnline(const frontend::RangeScan& scan, const core::Pose2& odom,
                  std::optional<int> node);
  /// Slam mode, idle: adopts the trimmed map if a trim finished meanwhile.
  void pollOnlineTrim();
  /// Runs `harvest` (the trimmer's) and adopts the map it returns, if any (true); what it throws
  /// is logged and the running map stays.
  bool adoptTrimmed(const std::function<std::unique_ptr<frontend::LaserSlam>()>& harvest);
  /// False if the other input owns the graph (the message is then counted as ignored).
  bool claim(Owner owner, const char* topic);
  void replaceGraph(std::unique_ptr<rrr::OnlineRrr> replacement);
  void publishChanges();
  void publishOutputs();
  void publishStatus();
  /// Slam mode: hands the map's inputs to map_publisher_ when someone subscribes.
  void offerMap();

  // Services (their own queue and thread).
  bool save(SaveGraph::Request& req, SaveGraph::Response& res);
  bool load(LoadGraph::Request& req, LoadGraph::Response& res);
  bool saveMap(SaveMap::Request& req, SaveMap::Response& res);
  bool loadMap(LoadMap::Request& req, LoadMap::Response& res);
  bool reset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool optimize(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool finish(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);

  // Timer thread.
  void broadcastTf(const ros::TimerEvent& event);

  NodeParams params_;
  ros::NodeHandle nh_, private_nh_;

  // Owned by the worker.
  std::unique_ptr<rrr::OnlineRrr> graph_;
  std::unique_ptr<frontend::LaserSlam> slam_;         // slam mode only
  std::unique_ptr<frontend::OnlineTrimmer> trimmer_;  // slam mode, trim_every_n_nodes > 0
  std::vector<ros::Time> node_stamps_;
  std::optional<core::Pose2> newest_node_odom_;  // slam mode: odom_frame pose of the newest node
  ros::Time last_scan_stamp_;
  bool map_dirty_ = false;
  std::chrono::steady_clock::time_point last_map_;
  Owner owner_ = Owner::kNone;
  core::KeyframeSelector keyframes_;
  std::optional<core::Pose2> last_keyframe_odom_;  // odometry pose of the newest odom node
  std::optional<Eigen::Matrix3d> last_keyframe_covariance_;  // its message's (x, y, yaw) block
  ros::Time last_odom_stamp_;
  bool dirty_ = false;
  double last_update_sec_ = 0.0;
  std::chrono::steady_clock::time_point last_publish_;

  // Shared with the subscriber threads.
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Input> queue_;
  bool stop_ = false;
  bool markers_requested_ = false;
  // Raised by ~reset (until its turn in the worker) and at shutdown: the graph's optimizations
  // stop within a step, so a long decision does not hold the reset or the shutdown up.
  std::atomic<bool> cancel_{false};
  // Input errors, throttled per topic and field (worker and tf filter threads).
  std::mutex input_errors_mutex_;
  InputErrorLog input_errors_;
  std::atomic<std::uint64_t> received_{0}, processed_{0}, malformed_{0}, ignored_{0};
  std::uint64_t decisions_published_ = 0, services_handled_ = 0;  // worker only
  // Slam mode: why the scans are dropped when they come from another sensor setup than the
  // loaded map's (empty: they do not); logged once, cleared with a new front end (worker only).
  std::string sensor_mismatch_;
  std::uint64_t sensor_mismatch_scans_ = 0;

  // Shared with the tf timer.
  std::mutex tf_mutex_;
  std::optional<core::Pose2> map_to_odom_;
  ros::Time last_tf_time_;  // timer thread only

  ros::Publisher decisions_pub_, markers_pub_, path_pub_, status_pub_, map_pub_;
  std::unique_ptr<MapPublisher> map_publisher_;  // slam mode only
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;   // slam mode only
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  // Scans wait in the filter until odom_frame -> their frame is known at their stamp.
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::LaserScan>> scan_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::LaserScan>> scan_filter_;
  std::mutex scan_order_mutex_;
  ArrivalOrder<const sensor_msgs::LaserScan*, ScanInput> scan_order_;  // waiting for tf
  ros::WallTimer scan_expiry_timer_;
  std::vector<ros::Subscriber> subscribers_;
  ros::CallbackQueue service_queue_;
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Timer tf_timer_;
  std::thread worker_;
};

}  // namespace rrr_graphslam::ros_adapter
