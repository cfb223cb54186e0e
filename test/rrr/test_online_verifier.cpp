// The other verifiers online (OnlineRrr with a VerifierChoice, online_verifier.h): candidates
// stay pending while their time cluster is open, decisions come as clusters close, and the end
// of a run decides exactly as the batch verifier (rrr_offline --verifier) on the same graph. The
// time clusters are RRR's (open_clusters.h).

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <string>
#include <vector>

#include "rrr_graphslam/rrr/online_rrr.h"
#include "rrr_graphslam/rrr/verifier_choice.h"

#include "streaming.h"
#include "synthetic.h"

namespace rrr_graphslam::rrr {
namespace {

const std::string kData = RRR_TEST_DATA_DIR;
using testing::Key;
using testing::keyOf;

constexpr int kGap = 10;

const testing::LabelledGraph& csailWithOutliers() {
  static const testing::LabelledGraph input = [] {
    testing::LabelledGraph g = testing::withOutliers(kData + "/csail.g2o.gz", 40, 1, 5);
    g.graph = testing::withoutDuplicateCandidates(g.graph);
    return g;
  }();
  return input;
}

OnlineRrrParams paramsFor(const VerifierChoice& choice) {
  OnlineRrrParams p;
  p.rrr.cluster_gap = kGap;
  p.verifier = choice;
  return p;
}

// The batch decision (rrr_offline --verifier V --cluster-gap 10), keyed by ends and measurement.
std::map<Key, Verdict> batchVerdicts(const core::PoseGraph& g, const VerifierChoice& choice) {
  VerificationGraph graph(g, {});
  RrrParams params;
  params.cluster_gap = kGap;
  const VerifierDecisions d = decideBatch(graph, choice, params);
  std::map<Key, Verdict> out;
  for (int k = 0; k < graph.numCandidates(); ++k) {
    const auto& e = g.edge(graph.candidate(k).edge);
    out[keyOf(e.from, e.to, graph.candidate(k).measurement)] =
        d.verdicts[static_cast<std::size_t>(k)];
  }
  return out;
}

std::vector<VerifierChoice> otherVerifiers() {
  VerifierChoice pcm, scgp, gnc_tls, gnc_gm;
  pcm.verifier = Verifier::kPcm;
  scgp.verifier = Verifier::kScgp;
  gnc_tls.verifier = gnc_gm.verifier = Verifier::kGnc;
  gnc_gm.gnc_loss = GncParams::Loss::kGemanMcClure;
  return {pcm, scgp, gnc_tls, gnc_gm};
}

std::string nameOf(const VerifierChoice& c) {
  return toString(c.verifier) + (c.verifier == Verifier::kGnc ? " " + toString(c.gnc_loss) : "");
}

TEST(OnlineVerifier, DecidesAsClustersCloseAndEndsAsTheBatchVerifier) {
  const core::PoseGraph& input = csailWithOutliers().graph;
  // Geman-McClure left out here (each closing runs a whole GNC, twice TLS's time; under the
  // sanitizers minutes): the cancel test below checks its end against the batch decision.
  std::vector<VerifierChoice> choices = otherVerifiers();
  choices.pop_back();
  for (const VerifierChoice& choice : choices) {
    SCOPED_TRACE(nameOf(choice));
    OnlineRrr online(paramsFor(choice));
    ASSERT_NO_FATAL_FAILURE(testing::stream(input, online, /*early=*/false, /*finish=*/false));

    // Before the end: the closed clusters are decided, the open ones pending, and every verdict
    // came with a change naming the verifier.
    int decided_before_the_end = 0;
    for (const DecisionChange& change : online.takeChanges()) {
      if (change.verdict == Verdict::kPending) continue;
      ++decided_before_the_end;
      EXPECT_GE(change.cluster, 0);
      EXPECT_EQ(change.reason.rfind(toString(choice.verifier), 0), 0u) << change.reason;
    }
    EXPECT_GT(decided_before_the_end, online.numCandidates() / 2);
    for (const DecisionRow& row : online.decisionRows()) {
      EXPECT_EQ(row.verdict == Verdict::kPending, row.cluster < 0);  // pending: its cluster open
    }
    const OnlineRrrStatus during = online.status();
    EXPECT_EQ(during.accepted + during.rejected + during.pending, during.candidates);
    EXPECT_EQ(static_cast<int>(online.mapPoses().size()), online.numNodes());

    online.finish();
    const std::map<Key, Verdict> batch = batchVerdicts(input, choice);
    ASSERT_EQ(static_cast<std::size_t>(online.numCandidates()), batch.size());
    int accepted = 0;
    for (int k = 0; k < online.numCandidates(); ++k) {
      const auto& c = online.candidate(k);
      const Key key = keyOf(online.nodeIds()[static_cast<std::size_t>(c.from)],
                            online.nodeIds()[static_cast<std::size_t>(c.to)], c.measurement);
      EXPECT_EQ(online.verdict(k), batch.at(key)) << "candidate " << k;
      accepted += online.verdict(k) == Verdict::kAccepted ? 1 : 0;
    }
    const OnlineRrrStatus end = online.status();
    EXPECT_EQ(end.pending, 0);
    EXPECT_EQ(end.open_clusters, 0);
    EXPECT_EQ(end.accepted, accepted);
    EXPECT_GT(end.optimizations, 0);
  }
}

// The map a batch verifier hands the robot is the optimum of the loops it accepted: the same
// poses as the batch decision's optimizer, continued by odometry past the last decision.
TEST(OnlineVerifier, TheMapIsTheAcceptedLoopsOptimum) {
  const core::PoseGraph& input = csailWithOutliers().graph;
  VerifierChoice gnc;
  gnc.verifier = Verifier::kGnc;
  OnlineRrr online(paramsFor(gnc));
  ASSERT_NO_FATAL_FAILURE(testing::stream(input, online, false));
  const core::PoseGraph saved = online.toPoseGraph();
  VerificationGraph batch(saved, {});
  RrrParams params;
  params.cluster_gap = kGap;
  decideBatch(batch, gnc, params);
  const std::vector<core::Pose2> map = online.mapPoses();
  ASSERT_EQ(map.size(), batch.optimizer().poses().size());
  for (std::size_t k = 0; k < map.size(); ++k) {
    EXPECT_LT((map[k] - batch.optimizer().poses()[k]).norm(), 1e-9) << "node " << k;
  }
}

// A graph replayed from a file (~load, a loaded map) is decided once, at its end, by the chosen
// verifier; what arrives after goes on online.
TEST(OnlineVerifier, ALoadedGraphIsDecidedByTheChosenVerifier) {
  const core::PoseGraph& input = csailWithOutliers().graph;
  VerifierChoice pcm;
  pcm.verifier = Verifier::kPcm;
  const auto loaded = OnlineRrr::fromPoseGraph(input, paramsFor(pcm));
  const std::map<Key, Verdict> batch = batchVerdicts(input, pcm);
  ASSERT_EQ(static_cast<std::size_t>(loaded->numCandidates()), batch.size());
  for (int k = 0; k < loaded->numCandidates(); ++k) {
    const auto& c = loaded->candidate(k);
    EXPECT_EQ(loaded->verdict(k),
              batch.at(keyOf(loaded->nodeIds()[static_cast<std::size_t>(c.from)],
                             loaded->nodeIds()[static_cast<std::size_t>(c.to)], c.measurement)));
    EXPECT_EQ(loaded->reason(k).rfind("pcm:", 0), 0u) << loaded->reason(k);
  }
}

TEST(OnlineVerifier, BadSettingsAreRefused) {
  OnlineRrrParams p;
  p.verifier.verifier = Verifier::kScgp;
  p.verifier.scgp_ratio = 0.5;
  EXPECT_THROW(OnlineRrr{p}, std::invalid_argument);
  try {
    validate(p);
    ADD_FAILURE() << "scgp_ratio 0.5 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("scgp_ratio"), std::string::npos) << e.what();
  }
}

// What ~reset does before it throws a graph away: with the cancel flag raised no decision runs
// (a batch verifier's decision can take seconds on a large map), and nothing it skipped is kept
// as if decided: PCM's kept pairs included, the end decides as the batch verifier.
TEST(OnlineVerifier, ARaisedCancelFlagStopsEveryDecision) {
  const core::PoseGraph& input = csailWithOutliers().graph;
  for (const VerifierChoice& choice : otherVerifiers()) {
    SCOPED_TRACE(nameOf(choice));
    OnlineRrr online(paramsFor(choice));
    std::atomic<bool> cancel{true};
    online.setCancelFlag(&cancel);
    ASSERT_NO_FATAL_FAILURE(testing::stream(input, online, false, /*finish=*/false));
    EXPECT_EQ(online.status().pending, online.numCandidates());
    EXPECT_EQ(online.status().optimizations, 0);
    cancel = false;
    online.finish();
    const std::map<Key, Verdict> batch = batchVerdicts(input, choice);
    for (int k = 0; k < online.numCandidates(); ++k) {
      const auto& c = online.candidate(k);
      EXPECT_EQ(online.verdict(k),
                batch.at(keyOf(online.nodeIds()[static_cast<std::size_t>(c.from)],
                               online.nodeIds()[static_cast<std::size_t>(c.to)], c.measurement)))
          << "candidate " << k;
    }
  }
}

}  // namespace
}  // namespace rrr_graphslam::rrr
