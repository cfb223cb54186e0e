// The core must stay ROS-free. On Debian the ROS headers live in /usr/include, so the compiler
// alone cannot enforce it; this test reads every core source and header instead.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

namespace {

// ROS packages' headers, message and service headers (any *_msgs / *_srvs, and this package's
// own generated ones: rrr_graphslam/CapitalizedName.h), message_filters, rosconsole and the
// adapter itself.
const std::regex kRosInclude(
    R"(^\s*#\s*include\s*[<"]()"
    R"((ros|tf|tf2|tf2_ros|tf2_msgs|nodelet|pluginlib|rosbag|roscpp|rosconsole|rostime|)"
    R"(message_filters|actionlib|dynamic_reconfigure|image_transport|xmlrpcpp|XmlRpc|)"
    R"(\w+_msgs|\w+_srvs|rrr_graphslam/ros)/)"
    R"(|rrr_graphslam/[A-Z]\w*\.h)"
    R"(|(ros|XmlRpc)\.h))");

// Folders whose every file must be ROS-free; each must exist (a renamed folder would otherwise
// pass unread).
const char* const kCoreFolders[] = {"include/rrr_graphslam/core",
                                    "src/core",
                                    "include/rrr_graphslam/rrr",
                                    "src/rrr",
                                    "include/rrr_graphslam/frontend",
                                    "src/frontend",
                                    "include/rrr_graphslam/sim",
                                    "src/sim",
                                    "src/tools",
                                    "src/bench"};

int expectNoRosIncludes(const std::filesystem::path& dir) {
  int files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    ++files;
    std::ifstream in(entry.path());
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      EXPECT_FALSE(std::regex_search(line, kRosInclude))
          << entry.path().string() << ":" << number << ": ROS include in the core: " << line;
    }
  }
  return files;
}

TEST(CoreLayering, ThePatternCatchesEveryKindOfRosHeader) {
  for (const char* line :
       {"#include <ros/ros.h>", "#include <ros/console.h>",
        "#include <rosconsole/macros_generated.h>", "#include <message_filters/subscriber.h>",
        "#include <tf2_ros/buffer.h>", "#include <tf2/utils.h>", "#include <nav_msgs/Odometry.h>",
        "#include <std_srvs/Trigger.h>", "#include \"rrr_graphslam/LoopCandidate.h\"",
        "#include \"rrr_graphslam/ros/params.h\"", "  #  include <sensor_msgs/LaserScan.h>",
        "#include <ros.h>"}) {
    EXPECT_TRUE(std::regex_search(std::string(line), kRosInclude)) << line;
  }
  for (const char* line :
       {"#include \"rrr_graphslam/core/se2.h\"", "#include <Eigen/Core>",
        "#include <mrpt/poses/CPose2D.h>", "#include <rosy/thing.h>", "// see ros/ros.h"}) {
    EXPECT_FALSE(std::regex_search(std::string(line), kRosInclude)) << line;
  }
}

TEST(CoreLayering, CoreSourcesIncludeNoRosHeaders) {
  const std::filesystem::path root(RRR_SOURCE_DIR);
  for (const char* dir : kCoreFolders) {
    ASSERT_TRUE(std::filesystem::is_directory(root / dir)) << dir << " is missing";
    EXPECT_GT(expectNoRosIncludes(root / dir), 0) << dir << " holds no file";
  }
}

}  // namespace
