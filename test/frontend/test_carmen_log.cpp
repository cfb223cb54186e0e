// The C++ CARMEN reader on the bundled ACES head (the Python reader's fixture too) and on bad
// lines.

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/carmen_log.h"
#include "rrr_graphslam/frontend/range_scan.h"

namespace rrr_graphslam::frontend {
namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

TEST(CarmenLog, ReadsTheAcesHead) {
  const CarmenLog log = readCarmenLog(std::string(RRR_TEST_DATA_DIR) + "/carmen/aces_head.clf.gz");
  ASSERT_EQ(log.scans.size(), 293U);
  const LaserRecord& first = log.scans.front();
  EXPECT_EQ(first.ranges.size(), 180U);
  EXPECT_DOUBLE_EQ(first.angle_min, -M_PI / 2);
  EXPECT_DOUBLE_EQ(first.angle_increment, M_PI / 180);
  EXPECT_FLOAT_EQ(static_cast<float>(first.max_range), 50.0F);  // ACES writes misses as 50 m
  EXPECT_GT(first.line, 0U);
  for (std::size_t k = 1; k < log.scans.size(); ++k) {
    EXPECT_GE(log.scans[k].timestamp, log.scans[k - 1].timestamp);
    EXPECT_GT(log.scans[k].line, log.scans[k - 1].line);
  }
  // Misses are not matched; every matching point lies within the range limits.
  const RangeScan scan = RangeScan::fromCarmen(first);
  const RangeScanParams params;
  for (const auto& p : matchingPoints(scan, params)) {
    EXPECT_LE((p - scan.laser_in_robot.head<2>()).norm(), params.max_range_m + 1e-9);
  }
}

TEST(CarmenLog, FlaserIncrementPutsBeamsOnWholeOrHalfDegrees) {
  EXPECT_DOUBLE_EQ(flaserIncrement(180), M_PI / 180);
  EXPECT_DOUBLE_EQ(flaserIncrement(181), M_PI / 180);
  EXPECT_DOUBLE_EQ(flaserIncrement(360), M_PI / 360);
  EXPECT_DOUBLE_EQ(flaserIncrement(361), M_PI / 360);
}

TEST(CarmenLog, ReadsRobotLaserWithItsOwnAngles) {
  const std::string path = writeTemp("robotlaser.clf",
                                     "# comment\nODOM 0 0 0 0 0 0 1.0 host 1.0\n"
                                     "ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 4 1.0 2.0 3.0 4.0 0 "
                                     "0.1 0.2 0.3 0.0 0.0 0.0 0 0 0 0 0 12.5 host 12.6\n");
  const CarmenLog log = readCarmenLog(path);
  ASSERT_EQ(log.scans.size(), 1U);
  EXPECT_DOUBLE_EQ(log.scans[0].angle_min, -1.5);
  EXPECT_DOUBLE_EQ(log.scans[0].angle_increment, 0.5);
  EXPECT_DOUBLE_EQ(log.scans[0].max_range, 20.0);
  EXPECT_DOUBLE_EQ(log.scans[0].timestamp, 12.5);
  EXPECT_EQ(log.scans[0].line, 3U);
  EXPECT_TRUE(log.scans[0].laserInRobot().isApprox(core::Pose2(0.1, 0.2, 0.3)));
}

TEST(CarmenLog, BadLinesNameFileLineAndField) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {"FLASER 3 1 2 3 0 0 0 0 0 0 1 h 1\nFLASER 3 1 x 3 0 0 0 0 0 0 2 h 2\n", ":2: field 3"},
      {"FLASER 3 1 2 3 0 0 0\n", "a reading count of 3 (field 1) leaves 0 fields"},
      // A count one too small or too large: every later field would be read one place off.
      {"FLASER 2 1 2 3 0 0 0 0 0 0 1 h 1\n", "expects 12 fields after the tag, found 13"},
      {"FLASER 4 1 2 3 0 0 0 0 0 0 1 h 1\n", "a reading count of 4 (field 1) leaves 3 fields"},
      {"FLASER 18446744073709551615 1 2 3 0 0 0 0 0 0 1 h 1\n",
       "a reading count of 18446744073709551615"},
      {"ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 4 1.0 2.0 3.0 4.0 18446744073709551614 "
       "0.1 0.2 0.3 0.0 0.0 0.0 0 0 0 0 0 12.5 host 12.6\n",
       "a remission count of 18446744073709551614"},
      {"ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 4 1.0 2.0 3.0 4.0 0 "
       "0.1 0.2 0.3 0.0 0.0 0.0 0 0 0 0 0 12.5 host\n",
       "a reading count of 4 (field 8) leaves 3 fields"},
      {"ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 4 1.0 2.0 3.0 4.0 1 5 "
       "0.1 0.2 0.3 0.0 0.0 0.0 0 0 0 0 0 12.5 host 12.6 extra\n",
       "expects 28 fields after the tag, found 29"},
      {"FLASER 3 1 nan 3 0 0 0 0 0 0 1 h 1\n", "not finite"},
      {"FLASER 3 1 -2 3 0 0 0 0 0 0 1 h 1\n", "negative"},
      {"FLASER 2 1e39 1 0 0 0 0 0 0 1 h 1\n", "beyond the single-precision range"},
      {"FLASER 1 1 0 0 0 0 0 0 1 h 1\n", "at least 2 readings"},
      {"ROBOTLASER1 0 -1.5 3.0 0 20 0.1 0 2 1 2 0 0 0 0 0 0 0 0 0 0 0 0 1 h 1\n", "resolution"},
      {"ODOM 0 0 0 0 0 0 1 h 1\n", "no FLASER or ROBOTLASER1 line"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const std::string path = writeTemp("bad" + std::to_string(k++) + ".clf", c.text);
    try {
      readCarmenLog(path);
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const core::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(readCarmenLog(::testing::TempDir() + "does_not_exist.clf"), core::InputError);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
