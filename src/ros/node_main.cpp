// rrr_graphslam_node: the same adapter as the nodelet, as a process of its own.

#include <exception>

#include <ros/ros.h>

#include "rrr_graphslam/ros/graph_slam_ros.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "rrr_graphslam");
  // The node handles outlive the adapter: when the last one goes, roscpp shuts down, rosconsole
  // with it, and a start-up error (a bad parameter) would never be printed.
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  try {
    rrr_graphslam::ros_adapter::GraphSlamRos adapter(nh, private_nh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("%s", e.what());
    return 1;
  }
  return 0;
}
