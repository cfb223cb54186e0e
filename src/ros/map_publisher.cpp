#include "rrr_graphslam/ros/map_publisher.h"

#include <exception>
#include <utility>

#include <nav_msgs/OccupancyGrid.h>
#include <ros/console.h>

#include "rrr_graphslam/ros/conversions.h"

namespace rrr_graphslam::ros_adapter {

MapPublisher::MapPublisher(ros::Publisher publisher, std::string frame, double resolution_m)
    : publisher_(std::move(publisher)),
      frame_(std::move(frame)),
      resolution_m_(resolution_m),
      thread_([this] { loop(); }) {}

MapPublisher::~MapPublisher() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void MapPublisher::offer(frontend::MapInputs inputs) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    next_ = std::move(inputs);
  }
  wake_.notify_one();
}

void MapPublisher::loop() {
  for (;;) {
    frontend::MapInputs inputs;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || next_.has_value(); });
      if (stop_) return;
      inputs = std::move(*next_);
      next_.reset();
    }
    try {
      nav_msgs::OccupancyGrid msg;
      msg.header.stamp = ros::Time::now();
      msg.header.frame_id = frame_;
      msg.info.map_load_time = msg.header.stamp;
      toOccupancyGridMsg(frontend::renderOccupancyMap(inputs, resolution_m_), msg);
      publisher_.publish(msg);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(10.0, "%s: map not rendered: %s", publisher_.getTopic().c_str(), e.what());
    }
  }
}

}  // namespace rrr_graphslam::ros_adapter
