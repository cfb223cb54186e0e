#include "rrr_graphslam/rrr/rrr.h"

#include <algorithm>
#include <chrono>
#include <map>

#include <Eigen/Dense>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/lago.h"
#include "rrr_graphslam/rrr/clustering.h"
#include "rrr_graphslam/rrr/consistency.h"
#include "rrr_graphslam/rrr/pairwise_consistency.h"

namespace rrr_graphslam::rrr {

std::string toString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted:
      return "accepted";
    case Verdict::kRejected:
      return "rejected";
    case Verdict::kPending:
      return "pending";
  }
  return "unknown";
}

Rrr::Rrr(VerificationGraph& graph, const RrrParams& params)
    : graph_(graph),
      params_(params),
      cluster_of_(static_cast<std::size_t>(graph.numCandidates()), -1),
      base_(graph.initialPoses()) {
  if (params_.reduced_intra_graph) {
    residuals_ = [this](const std::vector<int>& links) {
      return reducedGraphResiduals(graph_, links, params_.optimizer);
    };
  } else {
    residuals_ = [this](const std::vector<int>& links) {
      return fullGraphResiduals(graph_, links);
    };
  }
}

void Rrr::extendByOdometry(std::vector<core::Pose2>& poses) const {
  const OdometryChain& chain = graph_.chain();
  while (poses.size() < static_cast<std::size_t>(graph_.numNodes())) {
    const int k = static_cast<int>(poses.size());
    poses.push_back(k > 0 && chain.sameSession(k - 1, k)
                        ? core::compose(poses.back(), chain.relativePose(k - 1, k))
                        : graph_.initialPoses()[static_cast<std::size_t>(k)]);
  }
}

void Rrr::syncWithGraph() {
  cluster_of_.resize(static_cast<std::size_t>(graph_.numCandidates()), -1);
  extendByOdometry(base_);
}

std::vector<core::Pose2> Rrr::mapEstimate() const {
  std::vector<core::Pose2> poses = base_;
  extendByOdometry(poses);
  return poses;
}

bool Rrr::passedIntraTest(int candidate) const {
  const int c = clusterOf(candidate);
  if (c < 0) return true;
  const auto& passed = clusters_[static_cast<std::size_t>(c)].passed;
  return std::find(passed.begin(), passed.end(), candidate) != passed.end();
}

bool Rrr::droppedByJointLinkCheck(int candidate) const {
  const int c = clusterOf(candidate);
  if (c < 0) return false;
  const auto& kept = kept_links_[static_cast<std::size_t>(c)];
  return passedIntraTest(candidate) && std::find(kept.begin(), kept.end(), candidate) == kept.end();
}

int Rrr::addCluster(const std::vector<int>& members) {
  syncWithGraph();
  ++time_clusters_;
  if (!params_.split_mixed_clusters || members.size() < 2) {
    addTestedCluster(members, nullptr);
    return 1;
  }
  const LinkResiduals whole = residuals_(members);
  ++optimizations_;
  if (whole.total_chi2 < core::chi2Quantile(params_.alpha, 3 * static_cast<int>(members.size()))) {
    addTestedCluster(members, &whole);
    return 1;
  }
  const std::vector<std::vector<int>> groups =
      splitByPairwiseConsistency(graph_, members, params_.alpha);
  for (const std::vector<int>& group : groups) addTestedCluster(group, nullptr);
  return static_cast<int>(groups.size());
}

void Rrr::addTestedCluster(const std::vector<int>& members, const LinkResiduals* whole) {
  const int id = numClusters();
  Cluster cluster;
  cluster.time_cluster = time_clusters_ - 1;
  cluster.members = members;
  for (int k : members) cluster_of_[static_cast<std::size_t>(k)] = id;
  // The whole cluster's joint test, when addCluster ran it already, is not run twice.
  bool reused = false;
  const ResidualFunction residuals = [&](const std::vector<int>& links) {
    if (whole != nullptr && links == members) {
      reused = true;
      return *whole;
    }
    return residuals_(links);
  };
  const IntraClusterResult intra = intraClusterConsistency(members, params_.alpha, residuals);
  optimizations_ += intra.optimizations - (reused ? 1 : 0);  // addCluster counted that one
  cluster.passed = intra.kept;
  cluster.status = cluster.passed.empty() ? Status::kInconsistent : Status::kPending;
  clusters_.push_back(cluster);
  kept_links_.push_back(intra.kept);
}

std::vector<int> Rrr::clustersWith(Status status) const {
  std::vector<int> ids;
  for (int c = 0; c < numClusters(); ++c) {
    if (clusters_[static_cast<std::size_t>(c)].status == status) ids.push_back(c);
  }
  return ids;
}

bool Rrr::apply(const std::vector<int>& tested, const std::vector<int>& consistent) {
  bool grew = false;
  for (int c : tested) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  for (int c : consistent) {
    // previous_good_ comes from clustersWith(), in increasing id order.
    grew = grew || !std::binary_search(previous_good_.begin(), previous_good_.end(), c);
    clusters_[static_cast<std::size_t>(c)].status = Status::kGood;
  }
  base_ = graph_.optimizer().poses();
  return grew;
}

bool Rrr::largeCluster(int cluster) const {
  return params_.far_retry_min_links > 0 &&
         kept_links_[static_cast<std::size_t>(cluster)].size() >=
             static_cast<std::size_t>(params_.far_retry_min_links);
}

double Rrr::linkChi2(int candidate, const std::vector<core::Pose2>& poses) const {
  const LoopCandidate& c = graph_.candidate(candidate);
  const Eigen::Vector3d e = core::edgeError(poses[static_cast<std::size_t>(c.from)],
                                            poses[static_cast<std::size_t>(c.to)], c.measurement);
  return e.dot(c.information * e);
}

double Rrr::indexAt(int cluster, const std::vector<core::Pose2>& poses) const {
  const auto& kept = kept_links_[static_cast<std::size_t>(cluster)];
  double d2 = 0.0;
  for (int k : kept) d2 += linkChi2(k, poses);
  return d2 / core::chi2Quantile(params_.alpha, 3 * static_cast<int>(kept.size()));
}

std::vector<int> Rrr::robustMapLinks(const std::vector<int>& pending) const {
  // Random false links are mostly alone in their cluster, and long single links fill the
  // Cholesky factor; when clusters of two or more links hold most links, they make the map.
  std::vector<int> all, multi;
  auto add = [&](int c) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    all.insert(all.end(), kept.begin(), kept.end());
    if (kept.size() >= 2) multi.insert(multi.end(), kept.begin(), kept.end());
  };
  for (int c : clustersWith(Status::kGood)) add(c);
  for (int c : pending) add(c);
  return 2 * multi.size() >= all.size() ? multi : all;
}

std::vector<core::Pose2> Rrr::robustOrderingMap(const std::vector<int>& pending,
                                                const std::vector<core::Pose2>& initial) {
  const std::vector<int> links = robustMapLinks(pending);
  std::map<int, int> links_per_time_cluster;
  auto time_cluster = [&](int k) {
    return clusters_[static_cast<std::size_t>(clusterOf(k))].time_cluster;
  };
  for (int k : links) ++links_per_time_cluster[time_cluster(k)];
  std::vector<core::Pose2> full_weight =
      robustMap(graph_, links, initial, params_.dcs_phi, optimizations_);
  if (links_per_time_cluster.size() == links.size()) return full_weight;  // one link each
  auto support = [&](const std::vector<core::Pose2>& map, const std::vector<int>& clusters) {
    std::size_t agreeing = 0;
    for (int c : clusters) {
      if (indexAt(c, map) < 1.0) agreeing += kept_links_[static_cast<std::size_t>(c)].size();
    }
    return agreeing;
  };
  // Nothing was outvoted when the map agrees with (nearly) every link that made it.
  std::vector<int> voters;
  for (int k : links) voters.push_back(clusterOf(k));
  std::sort(voters.begin(), voters.end());
  voters.erase(std::unique(voters.begin(), voters.end()), voters.end());
  const std::size_t full_support = support(full_weight, pending);
  if (support(full_weight, voters) >= links.size() - links.size() / 100) return full_weight;

  std::vector<double> one_vote;
  one_vote.reserve(links.size());
  for (int k : links) one_vote.push_back(1.0 / links_per_time_cluster[time_cluster(k)]);
  std::vector<core::Pose2> voted =
      robustMap(graph_, links, initial, params_.dcs_phi, optimizations_, one_vote);
  return support(voted, pending) > full_support ? voted : full_weight;
}

void Rrr::realizeReverseRecover(const std::vector<core::Pose2>& initial, bool robust_ordering) {
  // Realize (and reverse): good + pending clusters, tested jointly.
  previous_good_ = clustersWith(Status::kGood);
  std::vector<int> tested = previous_good_;
  std::vector<core::Pose2> start = initial;
  const std::vector<int> pending = clustersWith(Status::kPending);
  if (robust_ordering && pending.size() > 1) {
    // Many clusters at once: test first those that agree with a map outliers cannot bend; the
    // others are tested in the recover step, against the good set's map.
    start = robustOrderingMap(pending, initial);
    std::vector<int> agreeing, set_aside;
    for (int c : pending) {
      (indexAt(c, start) < 1.0 ? agreeing : set_aside).push_back(c);
    }
    if (agreeing.empty()) {
      // The map agrees with nothing, so it orders nothing: test every cluster, as the paper does.
      agreeing.swap(set_aside);
      start = initial;
    }
    tested.insert(tested.end(), agreeing.begin(), agreeing.end());
    for (int c : set_aside) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  } else {
    tested.insert(tested.end(), pending.begin(), pending.end());
  }
  std::sort(tested.begin(), tested.end());
  InterClusterResult inter = interClusterConsistency(graph_, kept_links_, tested, start,
                                                     params_.alpha, params_.batch_removal_fraction);
  optimizations_ += inter.optimizations;
  // With robust ordering the clusters set aside count as not yet tried: the good set "grew".
  bool grew = apply(tested, inter.consistent) || (robust_ordering && pending.size() > 1);
  if (progress_) progress_("inter", 1, 1);
  if (robust_ordering) settleGoodMap();

  // Recover: while the good set grows, rejected clusters that agree with its map are retried;
  // when none does, large clusters far from the map get a direct test each.
  std::vector<char> far_tried(clusters_.size(), 0);
  for (int round = 0; round < params_.max_rounds; ++round) {
    std::vector<int> promising;
    if (grew) {
      for (int c : clustersWith(Status::kRejected)) {
        if (indexAt(c, base_) < params_.recover_gate) promising.push_back(c);
      }
    }
    if (promising.empty()) {
      if (!recoverFar(far_tried)) break;
      grew = true;
      continue;
    }
    previous_good_ = clustersWith(Status::kGood);
    tested = previous_good_;
    tested.insert(tested.end(), promising.begin(), promising.end());
    std::sort(tested.begin(), tested.end());
    const std::vector<core::Pose2> from = base_;
    inter = interClusterConsistency(graph_, kept_links_, tested, from, params_.alpha,
                                    params_.batch_removal_fraction);
    optimizations_ += inter.optimizations;
    grew = apply(tested, inter.consistent);
  }
  // Leave the optimizer holding the good set's solution.
  graph_.activateOnly(acceptedCandidates());
  graph_.optimizer().setPoses(base_);
}

bool Rrr::recoverFar(std::vector<char>& tried) {
  if (params_.far_retry_min_links <= 0) return false;
  std::vector<int> far;
  for (int c : clustersWith(Status::kRejected)) {
    if (!tried[static_cast<std::size_t>(c)] && largeCluster(c)) far.push_back(c);
  }
  if (far.empty()) return false;
  std::stable_sort(far.begin(), far.end(), [&](int a, int b) {
    return kept_links_[static_cast<std::size_t>(a)].size() >
           kept_links_[static_cast<std::size_t>(b)].size();
  });
  core::Optimizer& opt = graph_.optimizer();
  // Each try costs a full optimization: the linearized joint test at the good map (its factor's
  // marginal covariance) screens out clusters no motion the map allows could reconcile with it
  // (City10000 + 1000 random-grouped: false groups at predicted index 200 and more).
  factorGoodMap();
  far.erase(std::remove_if(far.begin(), far.end(),
                           [&](int c) {
                             const std::optional<double> predicted = predictedIndex(c);
                             return predicted && *predicted >= params_.recover_gate;
                           }),
            far.end());
  const double good_chi2 = opt.chi2();
  for (int c : far) {
    tried[static_cast<std::size_t>(c)] = 1;
    std::vector<int> tested = clustersWith(Status::kGood);
    tested.push_back(c);
    std::vector<int> links = acceptedCandidates();
    const auto& own = kept_links_[static_cast<std::size_t>(c)];
    links.insert(links.end(), own.begin(), own.end());
    graph_.activateOnly(links);
    opt.setPoses(base_);
    opt.optimize();
    ++optimizations_;
    const std::vector<core::Pose2>& poses = opt.poses();
    // Accepted only as is: the joint test passes, no cluster, good or new, had to go, and the
    // cluster raised the good set's chi2 by less than its own test threshold.
    bool consistent =
        opt.chi2() < core::chi2Quantile(params_.alpha, 3 * static_cast<int>(links.size())) &&
        opt.chi2() - good_chi2 <
            core::chi2Quantile(params_.alpha, 3 * static_cast<int>(own.size()));
    for (std::size_t i = 0; consistent && i < tested.size(); ++i) {
      consistent = indexAt(tested[i], poses) < 1.0;
    }
    if (consistent) {
      clusters_[static_cast<std::size_t>(c)].status = Status::kGood;
      base_ = poses;
      return true;
    }
  }
  return false;
}

void Rrr::settleGoodMap() {
  core::Optimizer& opt = graph_.optimizer();
  graph_.activateOnly(acceptedCandidates());
  opt.setPoses(base_);
  const double current = opt.chi2();
  opt.setPoses(core::lagoInitialization(opt));
  const core::OptimizationResult r = opt.optimize();
  ++optimizations_;
  // Lower by more than one link's test threshold: a better minimum, not the same one reached to
  // another tolerance (which could move a session only its weak prior holds).
  if (r.final_chi2 < current - core::chi2Quantile(params_.alpha, 3)) base_ = opt.poses();
  opt.setPoses(base_);
}

// A cluster's kept links linearized at base_, with the map's covariance of the nodes they touch
// (from the optimizer's last factorization).
struct Rrr::ClusterLinearization {
  Eigen::VectorXd residual;         // 3 per link
  Eigen::MatrixXd link_covariance;  // block diagonal
  Eigen::MatrixXd map_term;         // J Sigma_map J^T
};

Rrr::ClusterLinearization Rrr::linearizeCluster(int cluster) const {
  const auto& kept = kept_links_[static_cast<std::size_t>(cluster)];
  const std::vector<int> nodes = graph_.touchedNodes(kept);
  auto column = [&](int node) {
    return 3 * static_cast<Eigen::Index>(std::lower_bound(nodes.begin(), nodes.end(), node) -
                                         nodes.begin());
  };
  const Eigen::MatrixXd map_covariance = graph_.optimizer().covariance(nodes);
  const auto rows = 3 * static_cast<Eigen::Index>(kept.size());
  ClusterLinearization out;
  out.residual.resize(rows);
  out.link_covariance = Eigen::MatrixXd::Zero(rows, rows);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(rows, map_covariance.cols());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const LoopCandidate& c = graph_.candidate(kept[i]);
    const core::EdgeLinearization lin =
        core::linearizeEdge(base_[static_cast<std::size_t>(c.from)],
                            base_[static_cast<std::size_t>(c.to)], c.measurement);
    const auto r = 3 * static_cast<Eigen::Index>(i);
    out.residual.segment<3>(r) = lin.error;
    J.block<3, 3>(r, column(c.from)) += lin.J_from;
    J.block<3, 3>(r, column(c.to)) += lin.J_to;
    out.link_covariance.block<3, 3>(r, r) = c.information.inverse();
  }
  out.map_term = J * map_covariance * J.transpose();
  return out;
}

std::optional<double> Rrr::predictedIndex(int cluster) const {
  const auto& kept = kept_links_[static_cast<std::size_t>(cluster)];
  if (!graph_.optimizer().covarianceAvailable() || kept.empty()) return std::nullopt;
  const ClusterLinearization lin = linearizeCluster(cluster);
  // Adding the cluster: the innovation covariance is the links' plus the map's.
  const Eigen::MatrixXd S = lin.link_covariance + lin.map_term;
  const double d2 = lin.residual.dot(S.ldlt().solve(lin.residual));
  return d2 / core::chi2Quantile(params_.alpha, static_cast<int>(lin.residual.size()));
}

double Rrr::leaveOneOutIndex(int cluster) const {
  const ClusterLinearization lin = linearizeCluster(cluster);
  // Removing a cluster the map already contains: its own share comes off the links' covariance.
  const Eigen::MatrixXd S = lin.link_covariance - lin.map_term;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  if (ldlt.info() != Eigen::Success || (ldlt.vectorD().array() <= 0.0).any()) return 0.0;
  const double d2 = lin.residual.dot(ldlt.solve(lin.residual));
  return d2 / core::chi2Quantile(params_.alpha, static_cast<int>(lin.residual.size()));
}

Rrr::OnlineVerdict Rrr::checkAgainstMap(int cluster) const {
  if (indexAt(cluster, base_) < 1.0) return OnlineVerdict::kFits;
  // Accepting on the linearized test alone let doubtful clusters into the map updates, whose
  // removal rounds then cost more than the joint tests saved (measured on M3500 and City10000).
  const std::optional<double> predicted = predictedIndex(cluster);
  if (predicted && *predicted >= 1.0) return OnlineVerdict::kDoesNotFit;
  return OnlineVerdict::kNeedsJointTest;
}

void Rrr::optimizeGoodMap() {
  core::Optimizer& opt = graph_.optimizer();
  graph_.activateOnly(acceptedCandidates());
  opt.setPoses(base_);
  opt.optimize();
  ++optimizations_;
  base_ = opt.poses();
}

void Rrr::factorGoodMap() {
  graph_.activateOnly(acceptedCandidates());
  graph_.optimizer().setPoses(base_);
  // Otherwise one undamped factorization at the solution.
  if (!graph_.optimizer().covarianceAvailable()) optimizeGoodMap();
}

bool Rrr::leaveOneOutCheck() {
  factorGoodMap();
  std::vector<int> conflicting;
  for (int c : clustersWith(Status::kGood)) {
    if (!largeCluster(c) && indexAt(c, base_) < params_.loo_min_index) continue;
    if (leaveOneOutIndex(c) >= 1.0) conflicting.push_back(c);
  }
  if (conflicting.empty()) return false;
  for (int c : conflicting) clusters_[static_cast<std::size_t>(c)].status = Status::kRejected;
  optimizeGoodMap();
  return true;
}

void Rrr::decideIncrementally() {
  syncWithGraph();
  // Nodes added since the last joint test hang from the map by odometry; their covariance is
  // propagated along it at the map's poses (Optimizer::covariance).
  graph_.optimizer().setPoses(base_);
  // Online settings of the optimizer for this call; the final decision keeps the caller's.
  core::OptimizerParams& optimizer = graph_.optimizer().params();
  struct Restore {
    core::OptimizerParams& params;
    core::OptimizerParams saved;
    ~Restore() { params = saved; }
  } restore{optimizer, optimizer};
  optimizer.factor_updates = params_.incremental_factor_updates;
  optimizer.relative_tolerance =
      std::max(optimizer.relative_tolerance, params_.incremental_relative_tolerance);
  decideAgainstMap();
}

void Rrr::decideAgainstMap() {
  std::vector<int> joint;
  auto sort_out = [&](int c, Status if_not) {
    switch (checkAgainstMap(c)) {
      case OnlineVerdict::kFits:
        clusters_[static_cast<std::size_t>(c)].status = Status::kGood;
        ++unoptimized_accepts_;
        break;
      case OnlineVerdict::kDoesNotFit:
        clusters_[static_cast<std::size_t>(c)].status = if_not;
        break;
      case OnlineVerdict::kNeedsJointTest:
        joint.push_back(c);
        break;
    }
  };
  for (int c : clustersWith(Status::kPending)) sort_out(c, Status::kRejected);
  // Joint tests (realize / reverse) of the good set and the undecided clusters, which also fold
  // the clusters accepted since the last update into the map; while the good set grows, the
  // rejected clusters that now fit its map are recovered.
  for (int round = 0; round < params_.max_rounds; ++round) {
    if (joint.empty() && unoptimized_accepts_ < params_.incremental_map_update_every) return;
    unoptimized_accepts_ = 0;
    previous_good_ = clustersWith(Status::kGood);
    std::vector<int> tested = previous_good_;
    tested.insert(tested.end(), joint.begin(), joint.end());
    std::sort(tested.begin(), tested.end());
    const InterClusterResult inter = interClusterConsistency(
        graph_, kept_links_, tested, base_, params_.alpha, params_.batch_removal_fraction, true);
    optimizations_ += inter.optimizations;
    if (!graph_.optimizer().covarianceAvailable()) {
      graph_.optimizer().optimize();  // ends undamped, so the next clusters can use the gate
      ++optimizations_;
    }
    const bool grew = apply(tested, inter.consistent);
    joint.clear();
    if (!grew) return;
    for (int c : clustersWith(Status::kRejected)) {
      if (indexAt(c, base_) < params_.recover_gate) sort_out(c, Status::kRejected);
    }
  }
}

void Rrr::decideFromScratch() {
  syncWithGraph();
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    // Every link that passed the intra test takes part again, those the last joint link check
    // dropped included.
    Cluster& cluster = clusters_[c];
    kept_links_[c] = cluster.passed;
    cluster.status = cluster.passed.empty() ? Status::kInconsistent : Status::kPending;
  }
  base_ = graph_.initialPoses();
  unoptimized_accepts_ = 0;
  realizeReverseRecover(graph_.initialPoses(), true);
  leaveOneOutCheck();
  if (params_.joint_link_check) jointLinkCheck();
}

bool Rrr::jointLinkCheck() {
  const double threshold = core::chi2Quantile(params_.alpha, 3);
  bool dropped_any = false;
  for (int round = 0; round < params_.max_rounds; ++round) {
    // The worst failing link of each good cluster.
    struct Failing {
      double chi2;
      std::size_t cluster;
      std::size_t at;  // in the cluster's kept links
    };
    std::vector<Failing> failing;
    double worst = 0.0;
    for (int c : clustersWith(Status::kGood)) {
      const auto& kept = kept_links_[static_cast<std::size_t>(c)];
      Failing f{threshold, static_cast<std::size_t>(c), kept.size()};
      for (std::size_t i = 0; i < kept.size(); ++i) {
        const double d2 = linkChi2(kept[i], base_);
        if (d2 >= f.chi2) f = {d2, f.cluster, i};
      }
      if (f.at == kept.size()) continue;
      failing.push_back(f);
      worst = std::max(worst, f.chi2);
    }
    if (failing.empty()) break;
    for (const Failing& f : failing) {
      if (f.chi2 < params_.batch_removal_fraction * worst) continue;
      auto& kept = kept_links_[f.cluster];
      kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(f.at));
      // No link left: out of every test until the next decision from scratch.
      if (kept.empty()) clusters_[f.cluster].status = Status::kInconsistent;
    }
    dropped_any = true;
    optimizeGoodMap();
  }
  return dropped_any;
}

Verdict Rrr::verdict(int candidate) const {
  const int c = clusterOf(candidate);  // -1 also for candidates added since the last call
  if (c < 0) return Verdict::kPending;
  const Cluster& cluster = clusters_[static_cast<std::size_t>(c)];
  if (cluster.status == Status::kPending) return Verdict::kPending;
  if (cluster.status != Status::kGood) return Verdict::kRejected;
  const auto& kept = kept_links_[static_cast<std::size_t>(c)];
  return std::find(kept.begin(), kept.end(), candidate) != kept.end() ? Verdict::kAccepted
                                                                      : Verdict::kRejected;
}

std::vector<int> Rrr::acceptedCandidates() const {
  std::vector<int> links;
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    if (clusters_[c].status != Status::kGood) continue;
    links.insert(links.end(), kept_links_[c].begin(), kept_links_[c].end());
  }
  std::sort(links.begin(), links.end());
  return links;
}

std::vector<CandidateEnds> candidateEnds(const VerificationGraph& graph) {
  std::vector<CandidateEnds> ends;
  ends.reserve(static_cast<std::size_t>(graph.numCandidates()));
  for (int k = 0; k < graph.numCandidates(); ++k)
    ends.emplace_back(graph.candidate(k).from, graph.candidate(k).to);
  return ends;
}

void collectVerdicts(const Rrr& rrr, std::chrono::steady_clock::time_point start,
                     std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                     RrrSummary& summary) {
  const auto n = static_cast<std::size_t>(summary.candidates);
  verdicts.assign(n, Verdict::kPending);
  cluster_of.assign(n, -1);
  summary.clusters = rrr.numClusters();
  for (std::size_t k = 0; k < n; ++k) {
    verdicts[k] = rrr.verdict(static_cast<int>(k));
    cluster_of[k] = rrr.clusterOf(static_cast<int>(k));
    (verdicts[k] == Verdict::kAccepted ? summary.accepted : summary.rejected)++;
  }
  summary.optimizations = rrr.optimizations();
  summary.time_sec =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RrrSummary runBatchRrr(VerificationGraph& graph, const RrrParams& params,
                       std::vector<Verdict>& verdicts, std::vector<int>& cluster_of,
                       const ProgressFunction& progress) {
  const auto start = std::chrono::steady_clock::now();
  RrrSummary summary;
  summary.candidates = graph.numCandidates();
  const std::vector<CandidateEnds> ends = candidateEnds(graph);
  summary.cluster_gap = params.cluster_gap > 0 ? params.cluster_gap : deriveClusterGap(ends);
  const auto clusters = clusterCandidates(ends, summary.cluster_gap);

  Rrr rrr(graph, params);
  rrr.setProgress(progress);
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    rrr.addCluster(clusters[c]);
    if (progress && (c % 64 == 0 || c + 1 == clusters.size())) {
      progress("intra", static_cast<int>(c + 1), static_cast<int>(clusters.size()));
    }
  }
  rrr.decideFromScratch();

  collectVerdicts(rrr, start, verdicts, cluster_of, summary);
  return summary;
}

}  // namespace rrr_graphslam::rrr
