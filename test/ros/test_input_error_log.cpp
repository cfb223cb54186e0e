// Input errors: throttled per topic and field, quoted short and printable.

#include <gtest/gtest.h>

#include <string>

#include "rrr_graphslam/ros/input_error_log.h"

namespace rrr_graphslam::ros_adapter {
namespace {

TEST(InputErrorLog, OneLinePerTopicAndFieldPerPeriodThenTheCountSuppressed) {
  InputErrorLog log(1.0);
  int logged = 0;
  for (int k = 0; k < 20000; ++k) {  // a burst within 0.2 s
    logged += log.line("/odom", "pose.covariance (x, y, yaw): NaN", 100.0 + 1e-5 * k).has_value();
  }
  EXPECT_EQ(logged, 1);
  // Another field of the same topic, and the same field on another topic, are their own kinds.
  EXPECT_TRUE(log.line("/odom", "header.stamp 3 is not after 4", 100.5));
  EXPECT_TRUE(log.line("/pose_graph_edges", "pose.covariance (x, y, yaw): NaN", 100.5));
  // After the period, the next one says how many were suppressed.
  const auto next = log.line("/odom", "pose.covariance (x, y, yaw): inf", 101.5);
  ASSERT_TRUE(next);
  EXPECT_EQ(*next,
            "/odom: pose.covariance (x, y, yaw): inf (19999 more like it since the last one)");
  EXPECT_FALSE(log.line("/odom", "pose.covariance (x, y, yaw): NaN", 101.6));
}

TEST(InputErrorLog, QuotesAShortPrintablePrefix) {
  const std::string huge = "header.frame_id '" + std::string(2'000'000, 'a') + "' is unknown";
  InputErrorLog log(1.0, 100);
  const auto line = log.line("/scan", huge, 0.0);
  ASSERT_TRUE(line);
  EXPECT_LT(line->size(), 160u);
  EXPECT_NE(line->find("... (" + std::to_string(huge.size()) + " bytes)"), std::string::npos)
      << *line;
  EXPECT_EQ(quoteShort(std::string("a\0b\n\xff", 5), 50), "a\\x00b\\x0a\\xff");
  EXPECT_EQ(quoteShort("short", 50), "short");
}

}  // namespace
}  // namespace rrr_graphslam::ros_adapter
