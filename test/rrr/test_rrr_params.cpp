// RRR's parameter table: ranges and messages, presets, and the YAML that documents it.

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <type_traits>

#include "rrr_graphslam/rrr/rrr_params.h"

namespace rrr_graphslam::rrr {
namespace {

TEST(RrrParams, DefaultsAreValidAndNamesUniqueSnakeCase) {
  RrrParams p;
  EXPECT_NO_THROW(validate(p));
  std::set<std::string> names;
  forEachParam(p, [&](const ParamInfo& info, const auto&) {
    EXPECT_TRUE(std::regex_match(info.name, std::regex("[a-z][a-z0-9_]*"))) << info.name;
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_LE(info.low, info.high) << info.name;
    EXPECT_GT(std::string(info.doc).size(), 10u) << info.name;
  });
  EXPECT_GE(names.size(), 20u);
}

TEST(RrrParams, ValidateNamesTheParameterAndItsRange) {
  RrrParams p;
  p.alpha = 1.5;
  try {
    validate(p);
    FAIL() << "alpha 1.5 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("alpha = 1.5 is out of range: must be in [", 0), 0u)
        << e.what();
  }
  p = RrrParams();
  p.batch_removal_fraction = std::nan("");
  EXPECT_THROW(validate(p), std::invalid_argument);
  p = RrrParams();
  p.incremental_map_update_every = 0;
  EXPECT_THROW(validate(p), std::invalid_argument);
  p = RrrParams();
  p.recover_gate = std::numeric_limits<double>::infinity();  // the paper's rule
  EXPECT_NO_THROW(validate(p));
}

TEST(RrrParams, PaperPresetSwitchesEveryAdditionOff) {
  RrrParams p;
  p.alpha = 0.9;
  p.cluster_gap = 7;
  applyPreset("paper", p);
  EXPECT_EQ(p.alpha, 0.9);  // the paper's parameters stay
  EXPECT_EQ(p.cluster_gap, 7);
  int switched_on = 0;
  forEachParam(p, [&](const ParamInfo&, const auto& value) {
    if constexpr (std::is_same_v<std::decay_t<decltype(value)>, bool>) switched_on += value;
  });
  EXPECT_EQ(switched_on, 0);
  EXPECT_EQ(p.batch_removal_fraction, 1.0);
  EXPECT_TRUE(std::isinf(p.recover_gate));
  EXPECT_EQ(p.far_retry_min_links, 0);
  EXPECT_EQ(p.loo_joint_min_index, 0.0);
  EXPECT_EQ(p.incremental_rebatch_every, 0);
  EXPECT_NO_THROW(validate(p));

  applyPreset("default", p);
  EXPECT_TRUE(p.robust_ordering && p.joint_link_check && p.leave_one_out_check);
  EXPECT_EQ(p.loo_joint_min_index, 0.2);
  EXPECT_EQ(p.alpha, 0.9);
  EXPECT_THROW(applyPreset("papers", p), std::invalid_argument);
}

TEST(RrrParams, TheYamlDocumentsEveryParameterWithItsDefault) {
  std::ifstream file(std::string(RRR_TEST_DATA_DIR) + "/../../config/rrr_graphslam.yaml");
  ASSERT_TRUE(file) << "config/rrr_graphslam.yaml not found";
  std::stringstream text;
  text << file.rdbuf();
  const std::string yaml = text.str();
  EXPECT_NE(yaml.find("\npreset: default"), std::string::npos);
  const RrrParams defaults;
  forEachParam(defaults, [&](const ParamInfo& info, const auto& value) {
    // Set, or shown commented out where the preset decides.
    const std::regex line("\n(# )?" + std::string(info.name) + ": *([^ #\n]+)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(yaml, m, line)) << info.name << " missing from the YAML";
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, bool>) {
      EXPECT_EQ(m[2].str(), value ? "true" : "false") << info.name;
    } else if (std::string(info.name) != "cluster_gap") {  // online it must be set: 10
      EXPECT_DOUBLE_EQ(std::stod(m[2].str()), static_cast<double>(value)) << info.name;
    }
  });
}

}  // namespace
}  // namespace rrr_graphslam::rrr
