#include "rrr_graphslam/rrr/consistency.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <deque>
#include <map>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/lago.h"

namespace rrr_graphslam::rrr {
namespace {

// Initial poses for a small optimizer: compose along a breadth-first spanning tree from node 0,
// so nodes of another session start where the links put them.
void initializeBySpanningTree(core::Optimizer& opt) {
  const int n = opt.numNodes();
  std::vector<std::vector<int>> incident(static_cast<std::size_t>(n));
  for (int c = 0; c < opt.numConstraints(); ++c) {
    incident[static_cast<std::size_t>(opt.from(c))].push_back(c);
    incident[static_cast<std::size_t>(opt.to(c))].push_back(c);
  }
  std::vector<core::Pose2> poses = opt.poses();
  std::vector<char> placed(static_cast<std::size_t>(n), 0);
  for (int root = 0; root < n; ++root) {
    if (placed[static_cast<std::size_t>(root)]) continue;
    placed[static_cast<std::size_t>(root)] = 1;
    std::deque<int> queue{root};
    while (!queue.empty()) {
      const int a = queue.front();
      queue.pop_front();
      for (int c : incident[static_cast<std::size_t>(a)]) {
        const bool forward = opt.from(c) == a;
        const int b = forward ? opt.to(c) : opt.from(c);
        if (placed[static_cast<std::size_t>(b)]) continue;
        placed[static_cast<std::size_t>(b)] = 1;
        const core::Pose2& z = opt.measurement(c);
        poses[static_cast<std::size_t>(b)] =
            core::compose(poses[static_cast<std::size_t>(a)], forward ? z : core::inverse(z));
        queue.push_back(b);
      }
    }
  }
  opt.setPoses(poses);
}

}  // namespace

LinkResiduals reducedGraphResiduals(const VerificationGraph& graph, const std::vector<int>& links,
                                    const core::OptimizerParams& params) {
  const OdometryChain& chain = graph.chain();
  const std::vector<int> touched = graph.touchedNodes(links);
  std::map<int, int> local;
  core::Optimizer opt(params);
  for (int node : touched) local.emplace(node, opt.addNode(chain.chainPose(node)));
  for (std::size_t i = 0; i + 1 < touched.size(); ++i) {
    const int a = touched[i], b = touched[i + 1];
    if (!chain.sameSession(a, b)) continue;
    opt.addConstraint(local.at(a), local.at(b), chain.relativePose(a, b),
                      chain.relativeCovariance(a, b).inverse());
  }
  std::vector<int> link_constraint;
  for (int k : links) {
    const LoopCandidate& c = graph.candidate(k);
    link_constraint.push_back(
        opt.addConstraint(local.at(c.from), local.at(c.to), c.measurement, c.information));
  }
  initializeBySpanningTree(opt);
  LinkResiduals out;
  out.total_chi2 = opt.optimize().final_chi2;
  for (int c : link_constraint) out.link_chi2.push_back(opt.constraintChi2(c));
  return out;
}

LinkResiduals fullGraphResiduals(VerificationGraph& graph, const std::vector<int>& links) {
  LinkResiduals out;
  out.total_chi2 =
      std::max(0.0, graph.optimize(links, core::startFrom(graph.initialPoses())).final_chi2 -
                        graph.trustedChi2());
  const core::Optimizer& opt = graph.optimizer();
  for (int k : links) out.link_chi2.push_back(opt.constraintChi2(graph.candidate(k).constraint));
  return out;
}

std::string chi2Test(const char* statistic, double value, double alpha, int dof) {
  const double threshold = core::chi2Quantile(alpha, dof);
  char text[160];
  std::snprintf(text, sizeof text, "%s %.4g %s chi2(%g, %d) %.4g", statistic, value,
                value < threshold ? "<" : ">=", alpha, dof, threshold);
  return text;
}

std::string indexTest(const char* name, double index, double limit) {
  char text[96];
  std::snprintf(text, sizeof text, "%s %.4g %s %g", name, index, index < limit ? "<" : ">=", limit);
  return text;
}

std::string stopNote(core::StopReason stop) {
  return stop == core::StopReason::kConverged ? std::string()
                                              : " (optimizer: " + core::toString(stop) + ")";
}

IntraClusterResult intraClusterConsistency(const std::vector<int>& cluster, double alpha,
                                           const ResidualFunction& residuals,
                                           bool worst_link_removal) {
  IntraClusterResult result;
  std::vector<int> links = cluster;
  const double link_threshold = core::chi2Quantile(alpha, 3);
  while (!links.empty()) {
    const LinkResiduals r = residuals(links);
    ++result.optimizations;
    const int dof = 3 * static_cast<int>(links.size());
    const double total = failIfNotFinite(r.total_chi2);
    if (total < core::chi2Quantile(alpha, dof)) {
      for (std::size_t i = 0; i < links.size(); ++i) {
        const double d2 = failIfNotFinite(r.link_chi2[i]);
        if (d2 < link_threshold) {
          result.kept.push_back(links[i]);
        } else {
          result.dropped.push_back(links[i]);
          result.why_dropped.push_back(chi2Test("D2_l", d2, alpha, 3));
        }
      }
      return result;
    }
    const std::string joint = chi2Test("D2_G", total, alpha, dof);
    if (!worst_link_removal) {
      result.dropped.insert(result.dropped.end(), links.begin(), links.end());
      result.why_dropped.insert(result.why_dropped.end(), links.size(), joint);
      return result;
    }
    std::vector<double> d2(links.size());
    std::transform(r.link_chi2.begin(), r.link_chi2.end(), d2.begin(), failIfNotFinite);
    const auto worst =
        static_cast<std::size_t>(std::max_element(d2.begin(), d2.end()) - d2.begin());
    char text[64];
    std::snprintf(text, sizeof text, "worst link (D2_l %.4g) of a cluster with ", d2[worst]);
    result.dropped.push_back(links[worst]);
    result.why_dropped.push_back(text + joint);
    links.erase(links.begin() + static_cast<long>(worst));
  }
  return result;
}

namespace {

struct Conflict {
  std::size_t at;  // in the active clusters
  double index;    // its leave-one-out index
};

// The removable active cluster with the highest leave-one-out index at the optimizer's solution,
// if it is at least 1; factors the solution first when the last factorization is of something
// else (one optimization more).
std::optional<Conflict> mostConflicting(VerificationGraph& graph,
                                        const std::vector<std::vector<int>>& cluster_links,
                                        const std::vector<int>& active,
                                        const std::function<bool(int)>& removable, double alpha,
                                        int& optimizations) {
  core::Optimizer& opt = graph.optimizer();
  if (!opt.covarianceAvailable()) {
    opt.optimize();  // ends undamped at the solution, or damped at its iteration limit
    ++optimizations;
    if (!opt.covarianceAvailable() && !opt.factorAtCurrentPoses()) return std::nullopt;
  }
  std::vector<std::size_t> examined;  // in `active`
  std::vector<const std::vector<int>*> links;
  for (std::size_t i = 0; i < active.size(); ++i) {
    if (!removable(active[i])) continue;
    examined.push_back(i);
    links.push_back(&cluster_links[static_cast<std::size_t>(active[i])]);
  }
  const std::vector<double> index = leaveOneOutIndices(graph, links, opt.poses(), alpha);
  std::optional<Conflict> most;
  for (std::size_t k = 0; k < examined.size(); ++k) {
    if (index[k] >= 1.0 && (!most || index[k] > most->index))
      most = Conflict{examined[k], index[k]};
  }
  return most;
}

}  // namespace

InterClusterResult interClusterConsistency(VerificationGraph& graph,
                                           const std::vector<std::vector<int>>& cluster_links,
                                           const std::vector<int>& clusters,
                                           const std::vector<core::Pose2>& start, double alpha,
                                           double batch_fraction, bool restart,
                                           const std::vector<int>& kept_anyway,
                                           bool conflict_removal) {
  InterClusterResult result;
  std::vector<int> active = clusters;
  const core::Optimizer& opt = graph.optimizer();
  auto removable = [&](int c) {
    return !std::binary_search(kept_anyway.begin(), kept_anyway.end(), c);
  };
  // Each round removes at least one cluster, so there are at most clusters.size() + 1 rounds.
  for (std::size_t round = 0; round <= clusters.size(); ++round) {
    std::vector<int> links;
    for (int c : active) {
      const auto& l = cluster_links[static_cast<std::size_t>(c)];
      links.insert(links.end(), l.begin(), l.end());
    }
    // Online, `start` is the good set's map and a single new outlier bends the solution far
    // (tens of damped iterations to come back), so rounds restart from it. In batch the
    // previous round's solution is closer, as the clusters removed together pull many ways.
    const bool from_start = result.optimizations == 0 || restart;
    const core::OptimizationResult r =
        graph.optimize(links, from_start ? core::startFrom(start) : core::OptimizationRequest{});
    ++result.optimizations;
    result.stop = r.stop_reason;
    // What the links add to the trusted constraints' own residual (marginal constraints).
    result.chi2 = std::max(0.0, failIfNotFinite(opt.chi2()) - graph.trustedChi2());
    result.dof = 3 * static_cast<int>(links.size());
    if (active.empty()) break;

    std::vector<double> index(active.size());
    for (std::size_t i = 0; i < active.size(); ++i) {
      const auto& l = cluster_links[static_cast<std::size_t>(active[i])];
      double d2 = 0.0;
      for (int k : l) d2 += opt.constraintChi2(graph.candidate(k).constraint);
      index[i] = failIfNotFinite(d2 / core::chi2Quantile(alpha, 3 * static_cast<int>(l.size())));
    }
    double worst = 0.0;  // of the removable clusters
    bool any_removable = false;
    for (std::size_t i = 0; i < active.size(); ++i) {
      if (!removable(active[i])) continue;
      worst = any_removable ? std::max(worst, index[i]) : index[i];
      any_removable = true;
    }
    const bool joint_ok = result.chi2 < core::chi2Quantile(alpha, result.dof);
    if ((joint_ok && worst < 1.0) || !any_removable) {
      result.consistent_index = index;
      break;
    }

    const std::string joint =
        chi2Test("D2_G", result.chi2, alpha, result.dof) + stopNote(r.stop_reason);
    if (worst < 1.0 && conflict_removal) {
      const std::optional<Conflict> culprit =
          mostConflicting(graph, cluster_links, active, removable, alpha, result.optimizations);
      if (culprit) {
        result.removed.push_back(active[culprit->at]);
        result.why_removed.push_back(
            joint + ", most conflicting: " + indexTest("leave-one-out index", culprit->index));
        active.erase(active.begin() + static_cast<std::ptrdiff_t>(culprit->at));
        continue;
      }
    }
    // Remove the worst cluster and those nearly as bad; with every index below 1 (only the
    // joint test failed) that is the worst alone.
    const double threshold = worst < 1.0 ? worst : std::max(1.0, batch_fraction * worst);
    std::vector<int> keep;
    for (std::size_t i = 0; i < active.size(); ++i) {
      if (index[i] >= threshold && removable(active[i])) {
        result.removed.push_back(active[i]);
        result.why_removed.push_back(index[i] >= 1.0
                                         ? indexTest("CI", index[i]) + ", " + joint
                                         : joint + ", worst " + indexTest("CI", index[i]));
      } else {
        keep.push_back(active[i]);
      }
    }
    active.swap(keep);
  }
  result.consistent = active;
  result.consistent_index.resize(active.size(), 0.0);  // the empty set's last round
  return result;
}

}  // namespace rrr_graphslam::rrr

namespace rrr_graphslam::rrr {

std::vector<core::Pose2> robustMap(VerificationGraph& graph, const std::vector<int>& links,
                                   const std::vector<core::Pose2>& start, double phi,
                                   int& optimizations, const std::vector<double>& prior_weights,
                                   bool graduated) {
  auto prior = [&](std::size_t i) { return prior_weights.empty() ? 1.0 : prior_weights[i]; };
  constexpr int kMaxRounds = 40;
  constexpr double kAnnealing = 4.0;  // phi shrinks by this factor per round
  constexpr double kNegligibleWeight = 1e-4;
  core::Optimizer& opt = graph.optimizer();
  graph.activateOnly(links);
  opt.setPoses(start);
  // Graduated, the first round is plain least squares over every link; far from its minimum (a
  // drifted start), LAGO's linear estimate of it is where Gauss-Newton would have to go, without
  // the local minima on the way (ringCity + 100 random-grouped: recall 0.94 -> 1.00; City10000 +
  // 1000 random-grouped: 40 -> 25 s).
  if (graduated && core::farFromMinimum(opt)) opt.setPoses(core::lagoInitialization(opt));
  core::OptimizationRequest few_steps;
  few_steps.max_iterations = 3;  // a few steps per reweighting, so the map keeps up with phi
  // Graduated non-convexity: begin with phi above every residual (all weights ~1, plain least
  // squares, which closes loops however far odometry drifted), then shrink it to `phi`.
  double current_phi = phi;
  if (graduated) {
    for (int k : links)
      current_phi = std::max(current_phi, opt.constraintChi2(graph.candidate(k).constraint));
  }
  double previous_chi2 = -1.0;
  for (int round = 0; round < kMaxRounds; ++round) {
    for (std::size_t i = 0; i < links.size(); ++i) {
      const int c = graph.candidate(links[i]).constraint;
      const double s = std::min(1.0, 2.0 * current_phi / (current_phi + opt.constraintChi2(c)));
      const double weight = prior(i) * s * s;
      opt.setWeight(c, weight);
      // A link whose chi2 is ~200 phi and more weighs next to nothing; switched off, its fill-in
      // leaves the factor too (City10000 + 1000 random-grouped: 39 -> 21 s). It is switched on
      // again as soon as its weight rises.
      opt.setActive(c, weight >= kNegligibleWeight);
    }
    const core::OptimizationResult r = opt.optimize(few_steps);
    ++optimizations;
    // The map only orders RRR's tests, so 1% is settled enough once phi has reached its value.
    const bool settled =
        current_phi <= phi && previous_chi2 >= 0.0 &&
        std::abs(previous_chi2 - r.final_chi2) <= 1e-2 * std::max(1.0, r.final_chi2);
    previous_chi2 = r.final_chi2;
    if (settled) break;
    current_phi = std::max(phi, current_phi / kAnnealing);
  }
  for (int k : links) opt.setWeight(graph.candidate(k).constraint, 1.0);
  graph.activateOnly(links);
  return opt.poses();
}

}  // namespace rrr_graphslam::rrr
