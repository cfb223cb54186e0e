#pragma once
// Renders and publishes the slam-mode occupancy map on a thread of its own, so that a rendering
// (seconds on a large map) never delays a decision. The worker offers the newest inputs (the
// scans are shared, not copied); inputs offered before the last ones were rendered are skipped.

#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <ros/publisher.h>

#include "rrr_graphslam/frontend/map_render.h"

namespace rrr_graphslam::ros_adapter {

class MapPublisher {
 public:
  /// `publisher` advertises nav_msgs/OccupancyGrid (latched); the map is in `frame`.
  MapPublisher(ros::Publisher publisher, std::string frame, double resolution_m);
  ~MapPublisher();
  MapPublisher(const MapPublisher&) = delete;
  MapPublisher& operator=(const MapPublisher&) = delete;

  /// True while someone subscribes to the map: only then is it worth rendering.
  bool wanted() const { return publisher_.getNumSubscribers() > 0; }
  /// Renders and publishes `inputs` soon, replacing inputs offered before that wait.
  void offer(frontend::MapInputs inputs);

 private:
  void loop();

  ros::Publisher publisher_;
  std::string frame_;
  double resolution_m_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<frontend::MapInputs> next_;
  bool stop_ = false;
  std::thread thread_;  // last: started when everything else is set
};

}  // namespace rrr_graphslam::ros_adapter
