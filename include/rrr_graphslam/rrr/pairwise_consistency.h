#pragma once
// Pairwise consistency of loop candidates that lie close in time, and the split of a time
// cluster into sets of mutually consistent links.
//
// Two links i: a -> b and j: c -> d with a near c and b near d close a cycle
//   a -(z_i)-> b -(odometry)-> d -(z_j^-1)-> c -(odometry)-> a
// which is the identity when both are right (Olson's loop-closure hypothesis test, 2009; the
// pairwise test of PCM, Mangelson et al., ICRA 2018). Only the short odometry between a, c and
// between b, d enters, so the test holds however far odometry drifted between a and b. Its
// covariance is propagated to first order, with the steps shared by the two odometry pieces
// (short local loops) counted once, through OdometryChain::prefixCovariance.
//
// A time cluster may mix true links with a group of false ones (a place recognizer fooled along
// a corridor next to a true revisit). Greedy removal of the worst link from the whole cluster's
// compromise then keeps whichever side is larger; splitting first by pairwise consistency keeps
// both sides apart, so the inter-cluster test decides between them against the rest of the map.

#include <optional>
#include <vector>

#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

/// Mahalanobis distance (3 dof) of the cycle through candidates i and j, j taken in the direction
/// that pairs its ends with i's nearest ones. Empty when the cycle leaves a session (no odometry
/// joins the ends).
std::optional<double> pairwiseCycleChi2(const VerificationGraph& graph, int i, int j);

/// Splits `links` into groups: repeatedly the largest set of links that are pairwise consistent
/// (cycle chi2 below chi2(alpha, 3), or no cycle to test), taken out of the rest; so groups come
/// largest first. Links within a group keep their order in `links`.
std::vector<std::vector<int>> splitByPairwiseConsistency(const VerificationGraph& graph,
                                                         const std::vector<int>& links,
                                                         double alpha);

}  // namespace rrr_graphslam::rrr
