// The core must stay ROS-free. On Debian the ROS headers live in /usr/include, so the compiler
// alone cannot enforce it; this test reads every core source and header instead.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

namespace {

const std::regex kRosInclude(
    R"(^\s*#\s*include\s*[<"](ros|tf2|tf2_ros|nodelet|pluginlib|rosbag|\w+_msgs|\w+_srvs|rrr_graphslam/ros)/)");

void expectNoRosIncludes(const std::filesystem::path& dir) {
  ASSERT_TRUE(std::filesystem::exists(dir)) << dir;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path());
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      EXPECT_FALSE(std::regex_search(line, kRosInclude))
          << entry.path().string() << ":" << number << ": ROS include in the core: " << line;
    }
  }
}

TEST(CoreLayering, CoreSourcesIncludeNoRosHeaders) {
  const std::filesystem::path root(RRR_SOURCE_DIR);
  for (const char* dir : {"include/rrr_graphslam/core", "src/core", "include/rrr_graphslam/rrr",
                          "src/rrr", "include/rrr_graphslam/frontend", "src/frontend"}) {
    if (std::filesystem::exists(root / dir)) expectNoRosIncludes(root / dir);
  }
  expectNoRosIncludes(root / "src/core");
}

}  // namespace
