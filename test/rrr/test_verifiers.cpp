// The verifiers beside RRR (rrr_offline --verifier): PCM, SCGP and GNC on the same candidates,
// each checked for what its method promises and for what it is known to miss.

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <vector>

#include "rrr_graphslam/rrr/gnc.h"
#include "rrr_graphslam/rrr/pcm.h"
#include "rrr_graphslam/rrr/scgp.h"
#include "rrr_graphslam/rrr/verifier.h"
#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;

struct Counts {
  int tp = 0, fp = 0, fn = 0, tn = 0;
};

Counts score(const VerifierDecisions& d, const std::vector<bool>& truth) {
  Counts c;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const bool accepted = d.verdicts[k] == Verdict::kAccepted;
    c.tp += accepted && truth[k];
    c.fp += accepted && !truth[k];
    c.fn += !accepted && truth[k];
    c.tn += !accepted && !truth[k];
  }
  return c;
}

// What every verifier leaves: one verdict, cluster and reason per candidate, counts that add up,
// and the optimizer with exactly the accepted candidates switched on.
void expectWellFormed(const VerificationGraph& graph, const VerifierDecisions& d) {
  const auto m = static_cast<std::size_t>(graph.numCandidates());
  ASSERT_EQ(d.verdicts.size(), m);
  ASSERT_EQ(d.cluster_of.size(), m);
  ASSERT_EQ(d.reasons.size(), m);
  EXPECT_EQ(d.summary.candidates, graph.numCandidates());
  EXPECT_EQ(d.summary.accepted + d.summary.rejected, graph.numCandidates());
  int accepted = 0;
  for (int k = 0; k < graph.numCandidates(); ++k) {
    const bool on = d.verdicts[static_cast<std::size_t>(k)] == Verdict::kAccepted;
    accepted += on;
    EXPECT_EQ(graph.optimizer().isActive(graph.candidate(k).constraint), on) << k;
    EXPECT_FALSE(d.reasons[static_cast<std::size_t>(k)].empty()) << k;
  }
  EXPECT_EQ(accepted, d.summary.accepted);
}

TEST(Verifiers, NamesRoundTrip) {
  for (Verifier v : {Verifier::kRrr, Verifier::kPcm, Verifier::kScgp, Verifier::kGnc}) {
    EXPECT_EQ(parseVerifier(toString(v)), v);
  }
  EXPECT_THROW(parseVerifier("ransac"), std::invalid_argument);
  EXPECT_EQ(parseGncLoss("gm"), GncParams::Loss::kGemanMcClure);
  EXPECT_THROW(parseGncLoss("huber"), std::invalid_argument);
}

const testing::LabelledGraph& intelWithRandomOutliers() {
  static const testing::LabelledGraph input =
      testing::withOutliers(kData + "/intel.g2o.gz", 200, 1, 7);
  return input;
}

// Random false loops agree with nothing: PCM's clique, GNC's weights (either loss) leave them
// all out and keep the true loops.
TEST(Verifiers, PcmAndGncRejectRandomOutliers) {
  const testing::LabelledGraph& input = intelWithRandomOutliers();
  auto check = [&](const char* name, auto decide) {
    VerificationGraph graph(input.graph, {});
    const VerifierDecisions d = decide(graph);
    expectWellFormed(graph, d);
    const Counts c = score(d, input.candidate_is_true);
    EXPECT_EQ(c.fp, 0) << name;
    EXPECT_GE(c.tp, 0.98 * (c.tp + c.fn)) << name;
  };
  check("pcm", [](VerificationGraph& g) { return decidePcm(g); });
  check("gnc tls", [](VerificationGraph& g) { return decideGnc(g); });
  check("gnc gm", [](VerificationGraph& g) {
    GncParams p;
    p.loss = GncParams::Loss::kGemanMcClure;
    return decideGnc(g, p);
  });
}

// SCGP decides within a time cluster only: a false loop alone in its cluster has nothing to
// disagree with and is accepted (why it is not the product's verifier); one that falls in a
// cluster of true loops is outside the dominant group.
TEST(Verifiers, ScgpDecidesWithinTimeClustersOnly) {
  const testing::LabelledGraph& input = intelWithRandomOutliers();
  VerificationGraph graph(input.graph, {});
  const VerifierDecisions d = decideScgp(graph);
  expectWellFormed(graph, d);
  std::map<int, std::vector<int>> members;
  for (int k = 0; k < graph.numCandidates(); ++k) {
    members[d.cluster_of[static_cast<std::size_t>(k)]].push_back(k);
  }
  int alone = 0, among_true = 0;
  for (const auto& [cluster, ks] : members) {
    ASSERT_GE(cluster, 0);
    int true_links = 0;
    for (int k : ks) true_links += input.candidate_is_true[static_cast<std::size_t>(k)];
    for (int k : ks) {
      if (input.candidate_is_true[static_cast<std::size_t>(k)]) continue;
      const Verdict v = d.verdicts[static_cast<std::size_t>(k)];
      if (ks.size() == 1) {
        ++alone;
        EXPECT_EQ(v, Verdict::kAccepted) << k;
      } else if (true_links >= 3) {
        ++among_true;
        EXPECT_EQ(v, Verdict::kRejected) << k << " in a cluster of " << ks.size();
      }
    }
  }
  EXPECT_GT(alone, 100);
  EXPECT_GT(among_true, 0);
  // Small true clusters pass the uniqueness test: Intel's true loops agree closely (a pair passes
  // only with a cycle chi2 up to 2.2: l1/l2 = (1 + a)/(1 - a) with a = exp(-chi2/2)).
  int small_true = 0, small_true_accepted = 0;
  for (const auto& [cluster, ks] : members) {
    if (ks.size() < 2 || ks.size() > 3) continue;
    bool all_true = true, all_accepted = true;
    for (int k : ks) {
      all_true = all_true && input.candidate_is_true[static_cast<std::size_t>(k)];
      all_accepted = all_accepted && d.verdicts[static_cast<std::size_t>(k)] == Verdict::kAccepted;
    }
    if (!all_true) continue;
    ++small_true;
    small_true_accepted += all_accepted;
  }
  EXPECT_GT(small_true, 10);
  EXPECT_GE(small_true_accepted, 0.9 * small_true) << small_true_accepted << " of " << small_true;
}

TEST(Verifiers, ParametersOutOfRangeAreRefused) {
  const testing::LabelledGraph& input = intelWithRandomOutliers();
  VerificationGraph graph(input.graph, {});
  PcmParams pcm;
  pcm.alpha = 1.0;
  EXPECT_THROW(decidePcm(graph, pcm), std::invalid_argument);
  GncParams gnc;
  gnc.mu_step = 1.0;
  EXPECT_THROW(decideGnc(graph, gnc), std::invalid_argument);
  ScgpParams scgp;
  scgp.ratio = 0.5;
  EXPECT_THROW(decideScgp(graph, scgp), std::invalid_argument);
}

}  // namespace
}  // namespace rrr_graphslam::rrr
