#include "rrr_graphslam/rrr/gnc.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>

#include "rrr_graphslam/core/chi2.h"

namespace rrr_graphslam::rrr {

std::string toString(GncParams::Loss loss) { return core::choiceName(loss); }

GncParams::Loss parseGncLoss(const std::string& text) {
  return core::parseChoiceOrThrow<GncParams::Loss>(text, "gnc loss");
}

namespace {

void validate(const GncParams& params) {
  if (!(params.alpha > 0.0 && params.alpha < 1.0)) {
    throw std::invalid_argument("gnc: alpha = " + std::to_string(params.alpha) +
                                " is out of range: must be in (0, 1)");
  }
  if (!(params.mu_step > 1.0)) {
    throw std::invalid_argument("gnc: mu_step = " + std::to_string(params.mu_step) +
                                " is out of range: must be above 1");
  }
  if (params.max_iterations < 1) throw std::invalid_argument("gnc: max_iterations must be >= 1");
}

// Step 2's closed-form weight of a candidate with chi2 r2.
double weight(GncParams::Loss loss, double r2, double cbar2, double mu) {
  if (loss == GncParams::Loss::kGemanMcClure) {
    const double s = mu * cbar2 / (r2 + mu * cbar2);
    return s * s;
  }
  if (r2 <= mu / (mu + 1.0) * cbar2) return 1.0;
  if (r2 >= (mu + 1.0) / mu * cbar2) return 0.0;
  return std::sqrt(cbar2 / r2) * std::sqrt(mu * (mu + 1.0)) - mu;
}

}  // namespace

VerifierDecisions decideGnc(VerificationGraph& graph, const GncParams& params) {
  validate(params);
  const auto start = std::chrono::steady_clock::now();
  const int m = graph.numCandidates();
  core::Optimizer& optimizer = graph.optimizer();
  const double cbar2 = core::chi2Quantile(params.alpha, 3);
  VerifierDecisions out;
  RrrSummary& summary = out.summary;
  std::vector<double> w(static_cast<std::size_t>(m), 1.0);
  std::vector<double> r2(static_cast<std::size_t>(m), 0.0);
  auto residuals = [&] {
    double largest = 0.0;
    for (int k = 0; k < m; ++k) {
      r2[static_cast<std::size_t>(k)] = optimizer.constraintChi2(graph.candidate(k).constraint);
      largest = std::max(largest, r2[static_cast<std::size_t>(k)]);
    }
    return largest;
  };

  // 1. Start: every candidate on, weight 1, from the odometry.
  std::vector<int> all(static_cast<std::size_t>(m));
  std::iota(all.begin(), all.end(), 0);
  graph.optimize(all, core::startFrom(graph.initialPoses()));
  ++summary.optimizations;
  const double max_r2 = residuals();
  const bool gm = params.loss == GncParams::Loss::kGemanMcClure;
  int iterations = 0;
  if (max_r2 > cbar2) {
    // 2-3. Weights and weighted least squares, mu moving toward the loss's end point.
    double mu = gm ? 2.0 * max_r2 / cbar2 : cbar2 / (2.0 * max_r2 - cbar2);
    for (; iterations < params.max_iterations; ++iterations) {
      double change = 0.0;
      for (int k = 0; k < m; ++k) {
        const auto i = static_cast<std::size_t>(k);
        const double updated = weight(params.loss, r2[i], cbar2, mu);
        change += std::abs(updated - w[i]);
        w[i] = updated;
        const int constraint = graph.candidate(k).constraint;
        optimizer.setActive(constraint, updated > 0.0);
        if (updated > 0.0) optimizer.setWeight(constraint, updated);
      }
      optimizer.optimize();
      ++summary.optimizations;
      residuals();
      const bool last = gm && mu <= 1.0;
      if ((change < 1e-5 && iterations > 0) || last) break;
      mu = gm ? std::max(1.0, mu / params.mu_step) : mu * params.mu_step;
    }
  }

  // 4. Verdicts: TLS ends with weights 0 or 1 (above one half: an inlier); Geman-McClure's
  // weights stay graded (at mu = 1 a residual at the bound weighs 1/4): an inlier is a candidate
  // whose chi2 is within the bound. The accepted set optimized with weight 1.
  out.verdicts.assign(static_cast<std::size_t>(m), Verdict::kRejected);
  out.cluster_of.assign(static_cast<std::size_t>(m), -1);
  out.reasons.resize(static_cast<std::size_t>(m));
  std::vector<int> accepted;
  for (int k = 0; k < m; ++k) {
    const auto i = static_cast<std::size_t>(k);
    optimizer.setWeight(graph.candidate(k).constraint, 1.0);
    char reason[160];
    std::snprintf(reason, sizeof(reason),
                  "gnc (%s): weight %.3f after %d iterations (chi2 %.2f, inlier bound %.2f)",
                  toString(params.loss).c_str(), w[i], iterations, r2[i], cbar2);
    out.reasons[i] = reason;
    if (gm ? r2[i] < cbar2 : w[i] > 0.5) {
      out.verdicts[i] = Verdict::kAccepted;
      accepted.push_back(k);
    }
  }
  finishDecisions(graph, accepted, start, out);
  return out;
}

}  // namespace rrr_graphslam::rrr
