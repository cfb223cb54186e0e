// The front end's parameter table: names, ranges, messages, and the YAML that documents it.

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <type_traits>

#include "rrr_graphslam/frontend/laser_slam_params.h"
#include "rrr_graphslam/rrr/rrr_params.h"

namespace rrr_graphslam::frontend {
namespace {

std::string configYaml() {
  std::ifstream file(std::string(RRR_TEST_DATA_DIR) + "/../../config/rrr_graphslam.yaml");
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

TEST(LaserSlamParams, DefaultsAreValidAndNamesUniqueAcrossBothTables) {
  const LaserSlamParams p;
  EXPECT_NO_THROW(validate(p));
  std::set<std::string> names;
  rrr::forEachParam(p.rrr.rrr,
                    [&](const core::ParamInfo& info, const auto&) { names.insert(info.name); });
  int visited = 0;
  forEachSlamParam(p, [&](const core::ParamInfo& info, const auto& value) {
    ++visited;
    EXPECT_TRUE(std::regex_match(info.name, std::regex("[a-z][a-z0-9_]*"))) << info.name;
    EXPECT_TRUE(names.insert(info.name).second) << info.name << " named twice";
    EXPECT_LE(info.low, info.high) << info.name;
    EXPECT_GT(std::string(info.doc).size(), 10u) << info.name;
    EXPECT_NO_THROW(core::checkRange(info, value)) << info.name;
  });
  EXPECT_GE(visited, 25);
}

TEST(LaserSlamParams, ValidateNamesTheParameterAndItsRange) {
  LaserSlamParams p;
  p.loops.min_score = 1.5;
  try {
    validate(p);
    FAIL() << "min_score 1.5 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "min_score = 1.5 is out of range: must be in [0, 1]");
  }
  p = LaserSlamParams{};
  p.odometry_stddev.z() = std::nan("");
  try {
    validate(p);
    FAIL() << "a NaN stddev accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind("scan_odometry_stddev = [0.01, 0.01, nan] is out of range", 0),
        0u)
        << e.what();
  }
  p = LaserSlamParams{};
  p.local.submap.scans_per_submap = 1;
  EXPECT_THROW(validate(p), std::invalid_argument);
}

TEST(LaserSlamParams, RulesBetweenParametersNameThem) {
  // young_submap_scans needs no bound: it applies to a session's first submap only
  // (ActiveSubmaps, test_scan_matcher).
  LaserSlamParams p;
  p.local.submap.scans_per_submap = 10;
  p.local.submap.young_submap_scans = 20;
  EXPECT_NO_THROW(validate(p));

  // The ambiguity search's own place must hold the match's peak: two search cells at least.
  p = LaserSlamParams{};
  p.loops.ambiguity_exclusion.linear_m = 0.05;
  EXPECT_NO_THROW(validate(p));  // the gate is off (ambiguity_ratio 1)
  p.loops.ambiguity_ratio = 0.9;
  try {
    validate(p);
    FAIL() << "an ambiguity distance of one search cell accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("loop_ambiguity_distance = 0.05 m", 0), 0u) << e.what();
  }
  p.loops.ambiguity_exclusion.linear_m = 0.2;
  EXPECT_NO_THROW(validate(p));
  p.loops.ambiguity_exclusion.angular_rad = 0.0;
  EXPECT_THROW(validate(p), std::invalid_argument);
}

TEST(LaserSlamParams, SubmapInsertionRangeFollowsTheScanRange) {
  LaserSlamParams p;
  forEachSlamParam(p, [](const core::ParamInfo& info, auto& value) {
    if constexpr (std::is_same_v<std::decay_t<decltype(value)>, double>) {
      if (std::string(info.name) == "scan_max_range") value = 12.5;
    }
  });
  EXPECT_EQ(p.local.scan.max_range_m, 12.5);
  EXPECT_EQ(p.local.submap.max_insertion_range_m, 12.5F);
}

TEST(LaserSlamParams, ChoicesByName) {
  LocalSlamParams::Refinement r = LocalSlamParams::Refinement::kLeastSquares;
  EXPECT_TRUE(core::parseChoice("icp", r));
  EXPECT_EQ(r, LocalSlamParams::Refinement::kIcp);
  EXPECT_FALSE(core::parseChoice("least-squares", r));
  EXPECT_EQ(core::notAChoiceMessage({"scan_refinement", 0, 0, ""}, "x",
                                    core::choiceNames<LocalSlamParams::Refinement>()),
            "scan_refinement must be least_squares or icp, not 'x'");
}

TEST(LaserSlamParams, TheYamlDocumentsEveryParameterWithItsDefault) {
  const std::string yaml = configYaml();
  ASSERT_FALSE(yaml.empty()) << "config/rrr_graphslam.yaml not found";
  const LaserSlamParams defaults;
  forEachSlamParam(defaults, [&](const core::ParamInfo& info, const auto& value) {
    const std::regex line("\n" + std::string(info.name) + ": *([^#\n]*[^ #\n])");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(yaml, m, line)) << info.name << " missing from the YAML";
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_enum_v<T>) {
      EXPECT_EQ(m[1].str(), core::choiceName(value)) << info.name;
    } else if constexpr (std::is_same_v<T, bool>) {
      EXPECT_EQ(m[1].str(), value ? "true" : "false") << info.name;
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      std::string list = m[1].str();
      for (char& c : list) c = (c == '[' || c == ']' || c == ',') ? ' ' : c;
      std::istringstream in(list);
      Eigen::Vector3d v;
      ASSERT_TRUE(in >> v[0] >> v[1] >> v[2]) << info.name << ": " << m[1].str();
      EXPECT_TRUE(v.isApprox(value, 1e-9)) << info.name;
    } else {
      EXPECT_NEAR(std::stod(m[1].str()), static_cast<double>(value),
                  1e-9 * std::max(1.0, std::abs(static_cast<double>(value))))
          << info.name;
    }
  });
}

}  // namespace
}  // namespace rrr_graphslam::frontend
