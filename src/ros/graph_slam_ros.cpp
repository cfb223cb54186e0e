#include "rrr_graphslam/ros/graph_slam_ros.h"

#include <algorithm>
#include <chrono>
#include <future>
#include <stdexcept>

#include <geometry_msgs/TransformStamped.h>
#include <Eigen/LU>

#include "rrr_graphslam/LoopClosureDecision.h"
#include "rrr_graphslam/RrrStatus.h"
#include "rrr_graphslam/core/blas_kernel.h"
#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/core/odometry_noise.h"
#include "rrr_graphslam/core/stopwatch.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/ros/conversions.h"
#include "rrr_graphslam/ros/visualization.h"
#include "topics.h"

namespace rrr_graphslam::ros_adapter {

using core::secondsSince;

namespace {

const char* ownerName(int owner) {
  static const char* const kNames[] = {"auto", "odom", "edges", "scan"};
  return kNames[owner];
}

}  // namespace

GraphSlamRos::GraphSlamRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : params_(loadParams(private_nh)),
      nh_(nh),
      private_nh_(private_nh),
      graph_(std::make_unique<rrr::OnlineRrr>(params_.rrr)),
      keyframes_(params_.keyframes) {
  graph_->setCancelFlag(&cancel_);
  decisions_pub_ = private_nh_.advertise<LoopClosureDecision>("decisions", 1000);
  markers_pub_ = private_nh_.advertise<visualization_msgs::MarkerArray>(
      "markers", 1,
      [this](const ros::SingleSubscriberPublisher&) {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        markers_requested_ = true;
        queue_cv_.notify_one();
      },
      ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
  path_pub_ = private_nh_.advertise<nav_msgs::Path>("path", 1, true);
  status_pub_ = private_nh_.advertise<RrrStatus>("status", 10);
  if (!params_.map_file.empty() && params_.input_mode != "scan") {
    throw std::invalid_argument("parameter " + private_nh_.resolveName("map_file") +
                                " needs input_mode scan (slam mode)");
  }
  if (params_.mode == "localization" && params_.map_file.empty()) {
    throw std::invalid_argument("parameter " + private_nh_.resolveName("mode") +
                                " localization needs a map to localize in: set " +
                                private_nh_.resolveName("map_file"));
  }
  if (params_.input_mode == "scan") {
    if (params_.map_file.empty()) {
      startSlam();
    } else {
      const frontend::MapSnapshot map = frontend::readMapFile(params_.map_file);
      try {
        startSlam(&map);
      } catch (const std::exception& e) {
        throw std::invalid_argument(params_.map_file + ": " + e.what());
      }
      ROS_INFO("rrr_graphslam: %s %s: %zu sessions, %zu nodes, %zu submaps",
               params_.mode == "localization" ? "localizing in" : "continuing",
               params_.map_file.c_str(), map.sessions.size(), map.nodes.size(), map.submaps.size());
    }
    map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
    map_publisher_ =
        std::make_unique<MapPublisher>(map_pub_, params_.map_frame, params_.map_resolution);
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  }

  const auto hints = ros::TransportHints().tcpNoDelay();
  const auto q = static_cast<std::uint32_t>(params_.input_queue_size);
  subscribers_.push_back(nh_.subscribe<nav_msgs::Odometry>(
      kOdomTopic, q, [this](const nav_msgs::OdometryConstPtr& m) { enqueue(m, kOdomTopic); },
      ros::VoidConstPtr(), hints));
  subscribers_.push_back(nh_.subscribe<PoseGraphEdge>(
      kEdgesTopic, q, [this](const PoseGraphEdgeConstPtr& m) { enqueue(m, kEdgesTopic); },
      ros::VoidConstPtr(), hints));
  subscribers_.push_back(nh_.subscribe<LoopCandidate>(
      kCandidatesTopic, q, [this](const LoopCandidateConstPtr& m) { enqueue(m, kCandidatesTopic); },
      ros::VoidConstPtr(), hints));

  if (slam_) {
    scan_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::LaserScan>>(
        nh_, kScanTopic, q, hints);
    // Registered before the filter connects, so it sees every scan before the filter does.
    scan_sub_->registerCallback(&GraphSlamRos::scanArrived, this);
    scan_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::LaserScan>>(
        *scan_sub_, *tf_buffer_, params_.odom_frame, q, nh_);
    scan_filter_->registerCallback(&GraphSlamRos::scanCallback, this);
    scan_filter_->registerFailureCallback(
        [this](const sensor_msgs::LaserScanConstPtr& msg,
               tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
          dropScan(*msg, reason == tf2_ros::filter_failure_reasons::OutTheBack
                             ? "older than the tf buffer"
                         : reason == tf2_ros::filter_failure_reasons::EmptyFrameID
                             ? "header.frame_id is empty"
                             : "the tf2 message filter could not transform it (queue overflow or "
                               "tf failure)");
        });
    // rviz's "2D Pose Estimate": where the robot is in the loaded map, to relocalize from.
    subscribers_.push_back(nh_.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
        kInitialPoseTopic, 1,
        [this](const geometry_msgs::PoseWithCovarianceStampedConstPtr& m) { initialPose(*m); }));
  }

  worker_ = std::thread([this] { workerLoop(); });

  ros::NodeHandle services_nh(private_nh_);
  services_nh.setCallbackQueue(&service_queue_);
  services_.push_back(services_nh.advertiseService("save", &GraphSlamRos::save, this));
  services_.push_back(services_nh.advertiseService("load", &GraphSlamRos::load, this));
  services_.push_back(services_nh.advertiseService("reset", &GraphSlamRos::reset, this));
  services_.push_back(services_nh.advertiseService("optimize", &GraphSlamRos::optimize, this));
  services_.push_back(services_nh.advertiseService("finish", &GraphSlamRos::finish, this));
  services_.push_back(services_nh.advertiseService("save_map", &GraphSlamRos::saveMap, this));
  services_.push_back(services_nh.advertiseService("load_map", &GraphSlamRos::loadMap, this));
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();

  if (params_.publish_tf) {
    tf_timer_ =
        nh_.createTimer(ros::Duration(params_.tf_publish_period), &GraphSlamRos::broadcastTf, this);
  }
  if (slam_) {
    scan_expiry_timer_ = nh_.createWallTimer(ros::WallDuration(params_.tf_timeout / 2.0),
                                             &GraphSlamRos::expireScans, this);
    ROS_INFO("rrr_graphslam: slam mode: scans on %s placed by tf %s -> %s; map on %s",
             nh_.resolveName(kScanTopic).c_str(), params_.odom_frame.c_str(),
             params_.base_frame.c_str(), nh_.resolveName("map").c_str());
  }
  ROS_INFO("rrr_graphslam: listening on %s, %s and %s (input_mode %s, cluster_gap %d, alpha %g)",
           nh_.resolveName(kOdomTopic).c_str(), nh_.resolveName(kEdgesTopic).c_str(),
           nh_.resolveName(kCandidatesTopic).c_str(), params_.input_mode.c_str(),
           params_.rrr.rrr.cluster_gap, params_.rrr.rrr.alpha);
  if (const auto warning = core::blasKernelWarning())
    ROS_WARN("rrr_graphslam: %s", warning->c_str());
}

GraphSlamRos::~GraphSlamRos() {
  cancel_ = true;
  // No scan callback may run once the ordering state below goes.
  scan_filter_.reset();
  scan_sub_.reset();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
    queue_cv_.notify_one();
  }
  if (worker_.joinable()) worker_.join();
  service_spinner_->stop();
  tf_timer_.stop();
  scan_expiry_timer_.stop();
}

// ---- Subscriber threads ------------------------------------------------------------------------

void GraphSlamRos::enqueue(Input input, const char* topic) {
  const bool is_message = !std::holds_alternative<Command>(input);
  std::lock_guard<std::mutex> lock(queue_mutex_);
  if (is_message) ++received_;
  if (is_message && static_cast<int>(queue_.size()) >= params_.max_backlog) {
    ++malformed_;
    ++processed_;
    ROS_ERROR_THROTTLE(1.0,
                       "%s: message refused: the backlog holds %zu messages (max_backlog); RRR "
                       "cannot keep up with the input",
                       topic, queue_.size());
    return;
  }
  queue_.push_back(std::move(input));
  queue_cv_.notify_one();
}

void GraphSlamRos::logInputError(const char* topic, const std::string& what) {
  std::optional<std::string> line;
  {
    std::lock_guard<std::mutex> lock(input_errors_mutex_);
    line = input_errors_.line(nh_.resolveName(topic), what, ros::WallTime::now().toSec());
  }
  if (line) ROS_ERROR("%s", line->c_str());
}

bool GraphSlamRos::runInWorker(const std::function<std::string()>& job, std::string& message) {
  auto task = std::make_shared<std::packaged_task<std::string()>>(job);
  std::future<std::string> result = task->get_future();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stop_) {
      message = "shutting down";
      return false;
    }
    queue_.push_back(Command([task] { (*task)(); }));
    queue_cv_.notify_one();
  }
  try {
    message = result.get();
    return true;
  } catch (const std::exception& e) {
    message = e.what();
    return false;
  }
}

// ---- Worker thread -----------------------------------------------------------------------------

void GraphSlamRos::workerLoop() {
  for (;;) {
    Input input;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      if (queue_.empty() && !stop_) {
        // Idle: outputs at most every publish_period (a path and markers per message would cost
        // more than RRR at high input rates), the status at once (replays in lockstep wait on it).
        lock.unlock();
        pollOnlineTrim();
        if (dirty_ && secondsSince(last_publish_) >= params_.publish_period) publishOutputs();
        if (slam_ && map_dirty_ && secondsSince(last_map_) >= params_.map_publish_period) {
          offerMap();
        }
        publishStatus();
        lock.lock();
        const double wait =
            dirty_ ? params_.publish_period - secondsSince(last_publish_) : params_.status_period;
        queue_cv_.wait_for(lock, std::chrono::duration<double>(std::max(wait, 1e-3)),
                           [this] { return stop_ || !queue_.empty() || markers_requested_; });
      }
      if (stop_) {
        // Services waiting for an answer get one; queued messages are reported.
        std::size_t dropped = 0;
        for (Input& left : queue_) {
          if (auto* command = std::get_if<Command>(&left)) {
            (*command)();
          } else {
            ++dropped;
          }
        }
        if (dropped > 0)
          ROS_WARN("rrr_graphslam: shutting down with %zu messages unprocessed", dropped);
        queue_.clear();
        return;
      }
      if (markers_requested_) {
        markers_requested_ = false;
        dirty_ = true;
      }
      if (queue_.empty()) continue;
      input = std::move(queue_.front());
      queue_.pop_front();
    }
    const auto start = std::chrono::steady_clock::now();
    process(input);
    last_update_sec_ = secondsSince(start);
    if (!std::holds_alternative<Command>(input)) ++processed_;
    if (dirty_ && secondsSince(last_publish_) >= params_.publish_period) publishOutputs();
  }
}

void GraphSlamRos::process(const Input& input) {
  const char* topic = "service";
  try {
    if (const auto* odom = std::get_if<nav_msgs::OdometryConstPtr>(&input)) {
      topic = kOdomTopic;
      handleOdometry(**odom);
    } else if (const auto* edge = std::get_if<PoseGraphEdgeConstPtr>(&input)) {
      topic = kEdgesTopic;
      handleEdge(**edge);
    } else if (const auto* candidate = std::get_if<LoopCandidateConstPtr>(&input)) {
      topic = kCandidatesTopic;
      handleCandidate(**candidate);
    } else if (const auto* scan = std::get_if<ScanInput>(&input)) {
      topic = kScanTopic;
      handleScan(*scan);
    } else {
      ++services_handled_;
      std::get<Command>(input)();
    }
  } catch (const frontend::SensorMismatch& e) {
    // Not one bad message but every scan of this sensor: said once, in full, and in ~status.
    ++malformed_;
    ++sensor_mismatch_scans_;
    if (sensor_mismatch_.empty()) {
      sensor_mismatch_ = e.what();
      ROS_ERROR(
          "%s: %s; every scan from this sensor is dropped until ~load_map or ~reset "
          "(~status sensor_mismatch)",
          nh_.resolveName(topic).c_str(), e.what());
    } else {
      ROS_ERROR_THROTTLE(30.0, "%s: %llu scans dropped so far: another sensor setup than the map's",
                         nh_.resolveName(topic).c_str(),
                         static_cast<unsigned long long>(sensor_mismatch_scans_));
    }
  } catch (const std::invalid_argument& e) {
    ++malformed_;
    logInputError(topic, std::string(e.what()) + "; message dropped");
  } catch (const std::exception& e) {
    ++malformed_;
    logInputError(topic, std::string("processing failed: ") + e.what() + "; message dropped");
  }
  publishChanges();
}

bool GraphSlamRos::claim(Owner owner, const char* topic) {
  const Owner wanted = params_.input_mode == "odom"    ? Owner::kOdometry
                       : params_.input_mode == "edges" ? Owner::kEdges
                       : params_.input_mode == "scan"  ? Owner::kScan
                                                       : owner;
  if (owner != wanted || (owner_ != Owner::kNone && owner_ != owner)) {
    ++ignored_;
    ROS_WARN_THROTTLE(10.0, "%s: ignored: the graph is built from %s (input_mode %s)",
                      nh_.resolveName(topic).c_str(),
                      owner_ == Owner::kNone ? ownerName(static_cast<int>(wanted))
                                             : ownerName(static_cast<int>(owner_)),
                      params_.input_mode.c_str());
    return false;
  }
  return true;
}

void GraphSlamRos::handleOdometry(const nav_msgs::Odometry& msg) {
  if (!claim(Owner::kOdometry, kOdomTopic)) return;
  if (!msg.header.frame_id.empty() && msg.header.frame_id != params_.odom_frame) {
    throw std::invalid_argument("header.frame_id '" + msg.header.frame_id +
                                "' is not odom_frame '" + params_.odom_frame + "'");
  }
  if (!last_odom_stamp_.isZero() && msg.header.stamp <= last_odom_stamp_) {
    throw std::invalid_argument("header.stamp " + std::to_string(msg.header.stamp.toSec()) +
                                " is not after the previous message's " +
                                std::to_string(last_odom_stamp_.toSec()));
  }
  core::Pose2 pose;
  try {
    pose = toPose2(msg.pose.pose);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("pose.pose.") + e.what());
  }
  const std::optional<Eigen::Matrix3d> covariance = planarCovariance(msg.pose.covariance);
  if (covariance) {
    const std::string problem = core::informationProblem(*covariance);
    if (!problem.empty()) throw std::invalid_argument("pose.covariance (x, y, yaw): " + problem);
  }
  last_odom_stamp_ = msg.header.stamp;
  if (!keyframes_.accept(pose)) return;

  const bool continues = last_keyframe_odom_.has_value() && !graph().empty();
  const auto id = graph().empty() ? rrr::OnlineRrr::NodeId{0} : graph().nodeIds().back() + 1;
  if (continues) {
    graph().addOdometry(id - 1, id, core::between(*last_keyframe_odom_, pose),
                        stepInformation(pose, covariance));
  } else {
    graph().startSession(id, pose);  // first node, or the first after ~load
  }
  last_keyframe_covariance_ = covariance;
  owner_ = Owner::kOdometry;
  last_keyframe_odom_ = pose;
  node_stamps_.push_back(msg.header.stamp);
  dirty_ = true;
}

Eigen::Matrix3d GraphSlamRos::stepInformation(const core::Pose2& pose,
                                              const std::optional<Eigen::Matrix3d>& covariance) {
  // The message's covariance is the absolute pose's: the step's follows from two of them when
  // they grow as dead reckoning does; otherwise (constant, zero) the motion model gives it.
  if (covariance && last_keyframe_covariance_) {
    if (const auto step = core::stepCovarianceFromAbsolute(
            *last_keyframe_odom_, *last_keyframe_covariance_, pose, *covariance)) {
      return step->inverse();
    }
    ROS_INFO_ONCE(
        "%s: pose.covariance does not grow as dead reckoning would (constant?): each step's "
        "noise comes from odometry_stddev per metre driven and per radian turned",
        nh_.resolveName(kOdomTopic).c_str());
  }
  core::MotionNoise noise;
  noise.stddev = params_.odometry_stddev;
  noise.min_travel_m = params_.keyframes.min_travel_m;
  noise.min_rotation_rad = params_.keyframes.min_rotation_rad;
  return core::stepCovarianceFromMotion(core::between(*last_keyframe_odom_, pose), noise).inverse();
}

void GraphSlamRos::handleEdge(const PoseGraphEdge& msg) {
  if (!claim(Owner::kEdges, kEdgesTopic)) return;
  const int before = graph().numNodes();
  graph().addOdometry(msg.from_id, msg.to_id, toPose2(msg.measurement),
                      toInformation(msg.information));
  owner_ = Owner::kEdges;
  node_stamps_.resize(static_cast<std::size_t>(graph().numNodes()), msg.header.stamp);
  dirty_ = dirty_ || graph().numNodes() != before;
}

void GraphSlamRos::handleCandidate(const LoopCandidate& msg) {
  graph().addCandidate(msg.from_id, msg.to_id, toPose2(msg.measurement),
                       toInformation(msg.information));
  ROS_DEBUG("loop candidate %u -> %u from '%s' (score %g)", msg.from_id, msg.to_id,
            msg.source.c_str(), msg.score);
  dirty_ = true;
}

void GraphSlamRos::publishChanges() {
  for (const std::string& dropped : graph().takeDroppedCandidates()) {
    ++malformed_;
    logInputError(kCandidatesTopic, dropped);
  }
  // Verdicts reached while a reset cancels the optimizations are not published: that graph is
  // about to go.
  if (cancel_) return;
  const std::vector<rrr::DecisionChange> changes = graph().takeChanges();
  if (changes.empty()) return;
  dirty_ = true;
  map_dirty_ = map_dirty_ || slam_ != nullptr;  // a decision moves the map's poses
  const ros::Time now = ros::Time::now();
  for (const rrr::DecisionChange& change : changes) {
    try {
      LoopClosureDecision msg = toDecisionMsg(change, params_.map_frame, now);
      msg.source = slam_ ? frontend::toString(slam_->candidateSource(change.candidate))
                         : frontend::toString(frontend::LoopSource::kExternal);
      decisions_pub_.publish(msg);
      ++decisions_published_;
    } catch (const std::exception& e) {  // an id beyond uint32, a candidate with no source
      ROS_ERROR_THROTTLE(1.0, "%s: decision on candidate %d not published: %s",
                         decisions_pub_.getTopic().c_str(), change.candidate, e.what());
    }
  }
}

void GraphSlamRos::publishOutputs() {
  dirty_ = false;
  last_publish_ = std::chrono::steady_clock::now();
  const std::vector<core::Pose2> poses = graph().mapPoses();
  const ros::Time now = ros::Time::now();
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    if (graph().empty()) {
      map_to_odom_.reset();
    } else if (slam_) {
      // The graph's node poses are local-SLAM poses; odom_frame is the robot's odometry. A loaded
      // map's nodes belong to other runs: until this session has a node there is no map -> odom.
      if (!newest_node_odom_) {
        map_to_odom_.reset();
      } else {
        map_to_odom_ = core::compose(poses.back(), core::inverse(*newest_node_odom_));
      }
    } else {
      map_to_odom_ = graph().mapToOdom();
    }
  }
  path_pub_.publish(buildPath(graph(), poses, node_stamps_, params_.map_frame, now));
  if (slam_ && map_dirty_ && secondsSince(last_map_) >= params_.map_publish_period) offerMap();
  if (markers_pub_.getNumSubscribers() > 0) {
    markers_pub_.publish(buildMarkers(graph(), poses, params_.map_frame, now));
  }
}

void GraphSlamRos::publishStatus() {
  const rrr::OnlineRrrStatus s = graph().status();
  RrrStatus msg;
  msg.header.stamp = ros::Time::now();
  msg.input_mode = ownerName(static_cast<int>(owner_));
  msg.verifier = rrr::toString(params_.rrr.verifier.verifier);
  msg.nodes = static_cast<std::uint32_t>(s.nodes);
  msg.sessions = static_cast<std::uint32_t>(s.sessions);
  msg.candidates = static_cast<std::uint32_t>(s.candidates);
  msg.waiting_candidates = static_cast<std::uint32_t>(s.waiting_candidates);
  msg.clusters = static_cast<std::uint32_t>(s.clusters);
  msg.open_clusters = static_cast<std::uint32_t>(s.open_clusters);
  msg.accepted = static_cast<std::uint32_t>(s.accepted);
  msg.rejected = static_cast<std::uint32_t>(s.rejected);
  msg.pending = static_cast<std::uint32_t>(s.pending);
  msg.optimizations = static_cast<std::uint32_t>(s.optimizations);
  msg.messages_received = received_;
  msg.messages_processed = processed_;
  msg.messages_malformed = malformed_;
  msg.messages_ignored = ignored_;
  msg.decisions_published = decisions_published_;
  msg.services_handled = services_handled_;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    msg.backlog = static_cast<std::uint32_t>(queue_.size());
  }
  {
    std::lock_guard<std::mutex> lock(scan_order_mutex_);
    msg.backlog += static_cast<std::uint32_t>(scan_order_.waiting());
  }
  msg.last_update_sec = last_update_sec_;
  msg.tied_after_sec = -1.0;
  msg.marginal_edges = static_cast<std::uint32_t>(s.marginal_edges);
  msg.dense_factors = static_cast<std::uint32_t>(s.dense_factors);
  msg.lifelong = params_.lifelong;
  if (slam_) {
    msg.trimmed_submaps = static_cast<std::uint32_t>(slam_->lifelong().trimmed_submaps);
    msg.marginalized_nodes = static_cast<std::uint32_t>(slam_->lifelong().marginalized_nodes);
    msg.remembered_cells = static_cast<std::uint32_t>(frontend::rememberedCells(slam_->memory()));
    if (trimmer_) {
      msg.online_trims = static_cast<std::uint32_t>(trimmer_->replaced());
      if (const frontend::OnlineTrimRecord* last = trimmer_->last()) {
        msg.last_online_trim_sec = 1e-3 * last->trim_ms;
      }
    }
    const auto& sessions = slam_->sessions();
    msg.session = static_cast<std::uint32_t>(sessions.size() - 1);
    msg.tied_to_map = slam_->tied();
    msg.sensor_mismatch = !sensor_mismatch_.empty();
    if (const auto& tie = slam_->tie()) {
      msg.tied_after_sec = tie->timestamp - sessions.back().start_time;
    }
  }
  status_pub_.publish(msg);
}

// ---- Timer thread ------------------------------------------------------------------------------

void GraphSlamRos::broadcastTf(const ros::TimerEvent&) {
  std::optional<core::Pose2> map_to_odom;
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    map_to_odom = map_to_odom_;
  }
  const ros::Time now = ros::Time::now();
  if (!map_to_odom || now.isZero()) return;  // no node yet, or no /clock yet
  if (now == last_tf_time_) return;          // sim time paused: tf2 refuses repeated stamps
  last_tf_time_ = now;
  geometry_msgs::TransformStamped t;
  t.header.stamp = now + ros::Duration(params_.transform_tolerance);
  t.header.frame_id = params_.map_frame;
  t.child_frame_id = params_.odom_frame;
  t.transform = toTransformMsg(*map_to_odom);
  tf_broadcaster_.sendTransform(t);
}

}  // namespace rrr_graphslam::ros_adapter
