// rrr_graphslam/RRRNodelet: the adapter in a nodelet manager (zero-copy input from front ends in
// the same manager).

#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "rrr_graphslam/ros/graph_slam_ros.h"

namespace rrr_graphslam {

class RRRNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      adapter_ =
          std::make_unique<ros_adapter::GraphSlamRos>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s", e.what());
      throw;
    }
  }

  std::unique_ptr<ros_adapter::GraphSlamRos> adapter_;
};

}  // namespace rrr_graphslam

PLUGINLIB_EXPORT_CLASS(rrr_graphslam::RRRNodelet, nodelet::Nodelet)
