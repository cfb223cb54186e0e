#pragma once
// Graduated non-convexity (Yang, Antonante, Tzoumas, Carlone, "Graduated Non-Convexity for
// Robust Spatial Perception: From Non-Minimal Solvers to Global Outlier Rejection", RA-L 2020)
// on the product's optimizer, as a verifier beside RRR (verifier.h). Odometry (and marginal
// constraints) are known inliers, weight 1; every loop candidate gets a weight:
//   1. Start: all candidates on with weight 1, optimized from the odometry; r_k^2 each
//      candidate's chi2 there, cbar^2 = chi2(alpha, 3 dof) the inlier bound.
//   2. Black-Rangarajan duality: alternately the weights in closed form for the surrogate cost of
//      control parameter mu, and the weighted least squares from where the last one ended.
//      TLS: mu starts at cbar^2 / (2 max r^2 - cbar^2) (the surrogate is convex there) and grows
//      by `mu_step`; w = 1 for r^2 <= mu/(mu+1) cbar^2, 0 for r^2 >= (mu+1)/mu cbar^2,
//      cbar/r sqrt(mu(mu+1)) - mu between. Geman-McClure: mu starts at 2 max r^2 / cbar^2 and
//      shrinks by `mu_step` to 1; w = (mu cbar^2 / (r^2 + mu cbar^2))^2.
//   3. Stop when the weights no longer change (sum of changes below 1e-5), at the loss's end
//      point of mu, or after max_iterations.
//   4. Accepted: TLS, a weight above one half (its weights end at 0 or 1); Geman-McClure, whose
//      weights stay graded, a final chi2 within cbar^2 (weight at least 1/4 at mu = 1). The
//      accepted set is then optimized with weight 1.

#include "rrr_graphslam/rrr/verification_graph.h"
#include "rrr_graphslam/rrr/verifier.h"

namespace rrr_graphslam::rrr {

struct GncParams {
  enum class Loss { kTruncatedLeastSquares, kGemanMcClure };
  Loss loss = Loss::kTruncatedLeastSquares;
  /// The inlier bound: a candidate's chi2 below chi2(alpha, 3 dof).
  double alpha = 0.95;
  /// Factor by which mu moves each outer iteration (the paper's 1.4).
  double mu_step = 1.4;
  int max_iterations = 1000;
};

inline core::Choices<GncParams::Loss> choices(GncParams::Loss /*tag*/) {
  return {{GncParams::Loss::kTruncatedLeastSquares, "tls"}, {GncParams::Loss::kGemanMcClure, "gm"}};
}

/// "tls" or "gm".
std::string toString(GncParams::Loss loss);
/// Parses "tls" or "gm"; std::invalid_argument otherwise.
GncParams::Loss parseGncLoss(const std::string& text);

/// Decides every candidate of `graph` by GNC; leaves the accepted ones switched on with weight 1,
/// optimized. Throws std::invalid_argument for parameters out of range (named).
VerifierDecisions decideGnc(VerificationGraph& graph, const GncParams& params = {});

}  // namespace rrr_graphslam::rrr
