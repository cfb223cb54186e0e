#include "rrr_graphslam/ros/graph_slam_ros.h"

#include <algorithm>
#include <chrono>
#include <future>
#include <stdexcept>

#include <geometry_msgs/TransformStamped.h>
#include <Eigen/LU>

#include "rrr_graphslam/LoopClosureDecision.h"
#include "rrr_graphslam/RrrStatus.h"
#include "rrr_graphslam/core/constraint_check.h"
#include "rrr_graphslam/core/graph_io.h"
#include "rrr_graphslam/ros/conversions.h"
#include "rrr_graphslam/ros/visualization.h"
#include "rrr_graphslam/rrr/decisions_io.h"

namespace rrr_graphslam::ros_adapter {
namespace {

constexpr const char* kOdomTopic = "odom";
constexpr const char* kEdgesTopic = "pose_graph_edges";
constexpr const char* kCandidatesTopic = "loop_candidates";

const char* ownerName(int owner) {
  static const char* const kNames[] = {"auto", "odom", "edges"};
  return kNames[owner];
}

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// "map.g2o" -> "map.decisions.tsv" (also for .graph, .toro and their .gz).
std::string defaultDecisionsPath(std::string path) {
  for (const char* ext : {".gz", ".g2o", ".graph", ".toro"}) {
    const std::string e = ext;
    if (path.size() > e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) {
      path.resize(path.size() - e.size());
    }
  }
  return path + ".decisions.tsv";
}

void logServiceResult(const char* service, bool success, const std::string& message) {
  if (success) {
    ROS_INFO("%s: %s", service, message.c_str());
  } else {
    ROS_ERROR("%s failed: %s", service, message.c_str());
  }
}

}  // namespace

GraphSlamRos::GraphSlamRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : params_(loadParams(private_nh)),
      nh_(nh),
      private_nh_(private_nh),
      graph_(std::make_unique<rrr::OnlineRrr>(params_.rrr)),
      keyframes_(params_.keyframes) {
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

  worker_ = std::thread([this] { workerLoop(); });

  ros::NodeHandle services_nh(private_nh_);
  services_nh.setCallbackQueue(&service_queue_);
  services_.push_back(services_nh.advertiseService("save", &GraphSlamRos::save, this));
  services_.push_back(services_nh.advertiseService("load", &GraphSlamRos::load, this));
  services_.push_back(services_nh.advertiseService("reset", &GraphSlamRos::reset, this));
  services_.push_back(services_nh.advertiseService("optimize", &GraphSlamRos::optimize, this));
  services_.push_back(services_nh.advertiseService("finish", &GraphSlamRos::finish, this));
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();

  if (params_.publish_tf) {
    tf_timer_ =
        nh_.createTimer(ros::Duration(params_.tf_publish_period), &GraphSlamRos::broadcastTf, this);
  }
  ROS_INFO("rrr_graphslam: listening on %s, %s and %s (input_mode %s, cluster_gap %d, alpha %g)",
           nh_.resolveName(kOdomTopic).c_str(), nh_.resolveName(kEdgesTopic).c_str(),
           nh_.resolveName(kCandidatesTopic).c_str(), params_.input_mode.c_str(),
           params_.rrr.rrr.cluster_gap, params_.rrr.rrr.alpha);
}

GraphSlamRos::~GraphSlamRos() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
    queue_cv_.notify_one();
  }
  if (worker_.joinable()) worker_.join();
  service_spinner_->stop();
  tf_timer_.stop();
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
        if (dirty_ && secondsSince(last_publish_) >= params_.publish_period) publishOutputs();
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
    } else {
      ++services_handled_;
      std::get<Command>(input)();
    }
  } catch (const std::invalid_argument& e) {
    ++malformed_;
    ROS_ERROR("%s: %s; message dropped", nh_.resolveName(topic).c_str(), e.what());
  } catch (const std::exception& e) {
    ++malformed_;
    ROS_ERROR("%s: processing failed: %s; message dropped", nh_.resolveName(topic).c_str(),
              e.what());
  }
  publishChanges();
}

bool GraphSlamRos::claim(Owner owner, const char* topic) {
  const Owner wanted = params_.input_mode == "odom"    ? Owner::kOdometry
                       : params_.input_mode == "edges" ? Owner::kEdges
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
  Eigen::Matrix3d information =
      params_.odometry_stddev.cwiseAbs2().cwiseInverse().asDiagonal().toDenseMatrix();
  if (const auto covariance = planarCovariance(msg.pose.covariance)) {
    const std::string problem = core::informationProblem(*covariance);
    if (!problem.empty()) throw std::invalid_argument("pose.covariance (x, y, yaw): " + problem);
    information = covariance->inverse();
  }
  last_odom_stamp_ = msg.header.stamp;
  if (!keyframes_.accept(pose)) return;

  const bool continues = last_keyframe_odom_.has_value() && !graph_->empty();
  const auto id = graph_->empty() ? rrr::OnlineRrr::NodeId{0} : graph_->nodeIds().back() + 1;
  if (continues) {
    graph_->addOdometry(id - 1, id, core::between(*last_keyframe_odom_, pose), information);
  } else {
    graph_->startSession(id, pose);  // first node, or the first after ~load
  }
  owner_ = Owner::kOdometry;
  last_keyframe_odom_ = pose;
  node_stamps_.push_back(msg.header.stamp);
  dirty_ = true;
}

void GraphSlamRos::handleEdge(const PoseGraphEdge& msg) {
  if (!claim(Owner::kEdges, kEdgesTopic)) return;
  const int before = graph_->numNodes();
  graph_->addOdometry(msg.from_id, msg.to_id, toPose2(msg.measurement),
                      toInformation(msg.information));
  owner_ = Owner::kEdges;
  node_stamps_.resize(static_cast<std::size_t>(graph_->numNodes()), msg.header.stamp);
  dirty_ = dirty_ || graph_->numNodes() != before;
}

void GraphSlamRos::handleCandidate(const LoopCandidate& msg) {
  graph_->addCandidate(msg.from_id, msg.to_id, toPose2(msg.measurement),
                       toInformation(msg.information));
  ROS_DEBUG("loop candidate %u -> %u from '%s' (score %g)", msg.from_id, msg.to_id,
            msg.source.c_str(), msg.score);
  dirty_ = true;
}

void GraphSlamRos::publishChanges() {
  for (const std::string& dropped : graph_->takeDroppedCandidates()) {
    ++malformed_;
    ROS_ERROR("%s: %s", nh_.resolveName(kCandidatesTopic).c_str(), dropped.c_str());
  }
  const std::vector<rrr::DecisionChange> changes = graph_->takeChanges();
  if (changes.empty()) return;
  dirty_ = true;
  const ros::Time now = ros::Time::now();
  for (const rrr::DecisionChange& change : changes) {
    LoopClosureDecision msg;
    msg.header.stamp = now;
    msg.header.frame_id = params_.map_frame;
    msg.from_id = static_cast<std::uint32_t>(change.from);
    msg.to_id = static_cast<std::uint32_t>(change.to);
    msg.cluster = change.cluster;
    msg.verdict = toVerdictMsg(change.verdict);
    msg.previous_verdict = toVerdictMsg(change.previous);
    msg.reason = change.reason;
    msg.candidate = static_cast<std::uint32_t>(change.candidate);
    decisions_pub_.publish(msg);
    ++decisions_published_;
  }
}

void GraphSlamRos::publishOutputs() {
  dirty_ = false;
  last_publish_ = std::chrono::steady_clock::now();
  const std::vector<core::Pose2> poses = graph_->mapPoses();
  const ros::Time now = ros::Time::now();
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    if (graph_->empty()) {
      map_to_odom_.reset();
    } else {
      map_to_odom_ = graph_->mapToOdom();
    }
  }
  path_pub_.publish(buildPath(*graph_, poses, node_stamps_, params_.map_frame, now));
  if (markers_pub_.getNumSubscribers() > 0) {
    markers_pub_.publish(buildMarkers(*graph_, poses, params_.map_frame, now));
  }
}

void GraphSlamRos::publishStatus() {
  const rrr::OnlineRrrStatus s = graph_->status();
  RrrStatus msg;
  msg.header.stamp = ros::Time::now();
  msg.input_mode = ownerName(static_cast<int>(owner_));
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
  msg.last_update_sec = last_update_sec_;
  status_pub_.publish(msg);
}

void GraphSlamRos::replaceGraph(std::unique_ptr<rrr::OnlineRrr> graph) {
  graph_ = std::move(graph);
  owner_ = Owner::kNone;
  keyframes_.reset();
  last_keyframe_odom_.reset();
  last_odom_stamp_ = ros::Time();
  node_stamps_.assign(static_cast<std::size_t>(graph_->numNodes()), ros::Time::now());
  dirty_ = true;
  publishChanges();
}

// ---- Services ----------------------------------------------------------------------------------

bool GraphSlamRos::save(SaveGraph::Request& req, SaveGraph::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        if (req.path.empty()) throw std::invalid_argument("path is empty");
        const std::string decisions =
            req.decisions_path.empty() ? defaultDecisionsPath(req.path) : req.decisions_path;
        core::writePoseGraph(graph_->toPoseGraph(), req.path);
        rrr::writeDecisions(decisions, graph_->decisionRows());
        std::string written = req.path + " and " + decisions;
        if (!req.optimized_path.empty()) {
          core::writePoseGraph(graph_->optimizedPoseGraph(), req.optimized_path);
          written += " and " + req.optimized_path;
        }
        return "saved " + std::to_string(graph_->numNodes()) + " nodes and " +
               std::to_string(graph_->numCandidates()) + " candidates to " + written;
      },
      res.message);
  logServiceResult("~save", res.success, res.message);
  return true;
}

bool GraphSlamRos::load(LoadGraph::Request& req, LoadGraph::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        core::GraphReadOptions options;
        options.allow_disconnected = true;
        replaceGraph(
            rrr::OnlineRrr::fromPoseGraph(core::readPoseGraph(req.path, options), params_.rrr));
        const rrr::OnlineRrrStatus s = graph_->status();
        return "loaded " + std::to_string(s.nodes) + " nodes (" + std::to_string(s.sessions) +
               " sessions) and " + std::to_string(s.candidates) + " candidates from " + req.path +
               ": " + std::to_string(s.accepted) + " accepted, " + std::to_string(s.rejected) +
               " rejected";
      },
      res.message);
  logServiceResult("~load", res.success, res.message);
  return true;
}

bool GraphSlamRos::reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        replaceGraph(std::make_unique<rrr::OnlineRrr>(params_.rrr));
        received_ = processed_ = malformed_ = ignored_ = 0;
        decisions_published_ = 0;
        return "graph cleared";
      },
      res.message);
  return true;
}

bool GraphSlamRos::optimize(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        const auto start = std::chrono::steady_clock::now();
        graph_->decideClosedFromScratch();
        publishChanges();
        dirty_ = true;
        const rrr::OnlineRrrStatus s = graph_->status();
        return "closed clusters decided again in " + std::to_string(secondsSince(start)) +
               " s: " + std::to_string(s.accepted) + " accepted, " + std::to_string(s.rejected) +
               " rejected, " + std::to_string(s.pending) + " pending";
      },
      res.message);
  return true;
}

bool GraphSlamRos::finish(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = runInWorker(
      [&]() -> std::string {
        graph_->finish();
        publishChanges();
        dirty_ = true;
        const rrr::OnlineRrrStatus s = graph_->status();
        return "every cluster closed and decided: " + std::to_string(s.accepted) + " accepted, " +
               std::to_string(s.rejected) + " rejected";
      },
      res.message);
  return true;
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
  geometry_msgs::TransformStamped t;
  t.header.stamp = now + ros::Duration(params_.transform_tolerance);
  t.header.frame_id = params_.map_frame;
  t.child_frame_id = params_.odom_frame;
  t.transform = toTransformMsg(*map_to_odom);
  tf_broadcaster_.sendTransform(t);
}

}  // namespace rrr_graphslam::ros_adapter
