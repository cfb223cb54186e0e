#pragma once
// Single-cluster graph partitioning (Olson, "Recognizing places using spectral clustered local
// matches", Robotics and Autonomous Systems 2009), as a verifier beside RRR (verifier.h). It is a
// local method: it decides among the hypotheses of one place and never compares places, so it
// runs per time cluster (RRR's clusters, clustering.h), as MRPT's CLoopCloserERD runs it per
// partition:
//   1. Consistency matrix A of the cluster's candidates: A_ij = exp(-chi2_ij / 2), chi2_ij the
//      cycle test of the pair (pairwiseCycleChi2), 1 when no odometry joins their ends; A_ii = 1
//      (each candidate agrees with itself). So a pair passes step 4 only when it agrees well
//      (l1/l2 = (1 + a)/(1 - a) >= 2: a >= 1/3, cycle chi2 <= 2.2), and two candidates that
//      disagree are ambiguous (l1/l2 near 1): neither is accepted.
//   2. Dominant eigenvector v of A (eigenvalues l1 >= l2 >= ...).
//   3. Discretization: the candidates in decreasing order of v; the prefix u maximizing the
//      consistency density u^T A u / u^T u.
//   4. Local uniqueness: accepted when l1 / l2 >= `ratio` (Olson's 2); else the cluster is
//      ambiguous and nothing in it is accepted. A cluster of one candidate has nothing to be
//      inconsistent with: it is accepted.

#include "rrr_graphslam/rrr/verification_graph.h"
#include "rrr_graphslam/rrr/verifier.h"

namespace rrr_graphslam::rrr {

struct ScgpParams {
  /// Local uniqueness: the ratio of the two largest eigenvalues a cluster must reach.
  double ratio = 2.0;
  /// Time clusters' gap in nodes; 0: derived from the candidates (deriveClusterGap).
  int cluster_gap = 0;
};

/// Decides every candidate of `graph` by SCGP per time cluster; leaves the accepted ones switched
/// on, optimized. Throws std::invalid_argument for ratio < 1 or a negative cluster_gap.
VerifierDecisions decideScgp(VerificationGraph& graph, const ScgpParams& params = {});

}  // namespace rrr_graphslam::rrr
