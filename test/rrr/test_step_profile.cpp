// The step profile: nested steps charge their own time and work only, and on a real decision
// every optimization and factorization is charged to a named step.

#include <gtest/gtest.h>

#include <chrono>
#include <numeric>
#include <thread>

#include "rrr_graphslam/rrr/incremental_rrr.h"
#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/step_profile.h"

#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

StepProfile::Counters counters(int optimizations, int factorizations, double flops) {
  StepProfile::Counters c;
  c.optimizations = optimizations;
  c.factorizations.factorizations = factorizations;
  c.factorizations.flops = flops;
  return c;
}

const StepCost& costOf(const std::vector<StepCost>& steps, const std::string& name) {
  for (const StepCost& s : steps) {
    if (s.step == name) return s;
  }
  throw std::runtime_error("no step " + name);
}

TEST(StepProfile, ANestedStepIsChargedToItselfNotToItsParent) {
  StepProfile profile;
  profile.enter("outer", counters(0, 0, 0));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  profile.enter("inner", counters(2, 1, 100));
  std::this_thread::sleep_for(std::chrono::milliseconds(40));
  profile.leave(counters(7, 4, 400));  // inner: 5 optimizations, 3 factorizations, 300 flops
  profile.enter("inner", counters(7, 4, 400));
  profile.leave(counters(8, 4, 400));
  profile.leave(counters(9, 5, 450));  // outer: 2 + 1 optimizations, 1 + 1 factorizations

  ASSERT_EQ(profile.steps().size(), 2u);
  const StepCost& outer = costOf(profile.steps(), "outer");
  const StepCost& inner = costOf(profile.steps(), "inner");
  EXPECT_EQ(outer.calls, 1);
  EXPECT_EQ(inner.calls, 2);
  EXPECT_EQ(outer.optimizations, 3);
  EXPECT_EQ(inner.optimizations, 6);
  EXPECT_EQ(outer.factorizations, 2);
  EXPECT_EQ(inner.factorizations, 3);
  EXPECT_DOUBLE_EQ(outer.factorization_flops, 150.0);
  EXPECT_DOUBLE_EQ(inner.factorization_flops, 300.0);
  EXPECT_GE(inner.seconds, 0.035);
  EXPECT_GE(outer.seconds, 0.015);
  EXPECT_LT(outer.seconds, inner.seconds) << "the inner step's 40 ms are not the outer one's";
  // The table has a line per step and one for the time outside them.
  const std::string table = formatStepProfile(profile.steps(), 1.0);
  EXPECT_NE(table.find("outer"), std::string::npos);
  EXPECT_NE(table.find("inner"), std::string::npos);
  EXPECT_NE(table.find("outside the steps"), std::string::npos);
}

// Every optimization a decision runs is inside a named step, and each step's factorizations are
// those of the verification graph's optimizer.
void expectEveryOptimizationCharged(const RrrSummary& summary, const VerificationGraph& graph) {
  ASSERT_FALSE(summary.steps.empty());
  const int optimizations =
      std::accumulate(summary.steps.begin(), summary.steps.end(), 0,
                      [](int sum, const StepCost& s) { return sum + s.optimizations; });
  EXPECT_EQ(optimizations, summary.optimizations);
  const int factorizations =
      std::accumulate(summary.steps.begin(), summary.steps.end(), 0,
                      [](int sum, const StepCost& s) { return sum + s.factorizations; });
  EXPECT_GT(factorizations, 0);
  EXPECT_LE(factorizations, graph.optimizer().factorizationWork().factorizations);
  double seconds = 0.0;
  for (const StepCost& s : summary.steps) {
    seconds += s.seconds;
    EXPECT_GE(s.seconds, 0.0) << s.step;
    EXPECT_GE(s.calls, 1) << s.step;
    if (s.factorizations > 0) {
      EXPECT_GT(s.factorization_flops, 0.0) << s.step;
    }
  }
  EXPECT_LE(seconds, summary.time_sec * 1.01 + 1e-3);
}

TEST(StepProfile, ABatchDecisionChargesEveryOptimizationToAStep) {
  const testing::LabelledGraph input = testing::withOutliers(kData + "/intel.g2o.gz", 100, 10, 7);
  VerificationGraph graph(input.graph, {});
  std::vector<Verdict> verdicts;
  std::vector<int> cluster_of;
  const RrrSummary summary = runBatchRrr(graph, {}, verdicts, cluster_of);
  expectEveryOptimizationCharged(summary, graph);
  EXPECT_GE(costOf(summary.steps, "intra-cluster test").calls, 1);
  EXPECT_GE(costOf(summary.steps, "realize").calls, 1);
  EXPECT_GE(costOf(summary.steps, "robust ordering: full-weight map").optimizations, 1);
}

TEST(StepProfile, AnIncrementalRunChargesItsOnlineSteps) {
  const testing::LabelledGraph input = testing::withOutliers(kData + "/intel.g2o.gz", 100, 10, 7);
  RrrParams params;
  params.cluster_gap = 3;
  VerificationGraph graph(input.graph, params.optimizer);
  std::vector<Verdict> verdicts;
  std::vector<int> cluster_of;
  const RrrSummary summary = runIncrementalRrr(graph, params, verdicts, cluster_of);
  ASSERT_FALSE(summary.steps.empty());
  EXPECT_GE(costOf(summary.steps, "online decision").calls, 1);
  EXPECT_GE(costOf(summary.steps, "online map check").calls, 1);
  EXPECT_GE(costOf(summary.steps, "decision from scratch").calls, 1);  // the final one
}

}  // namespace
}  // namespace rrr_graphslam::rrr
