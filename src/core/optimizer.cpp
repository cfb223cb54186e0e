#include "rrr_graphslam/core/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "rrr_graphslam/core/union_find.h"

namespace rrr_graphslam::core {

std::string toString(StopReason reason) {
  switch (reason) {
    case StopReason::kConverged:
      return "converged";
    case StopReason::kMaxIterations:
      return "max-iterations";
    case StopReason::kSingular:
      return "singular";
    case StopReason::kDiverged:
      return "diverged";
    case StopReason::kCancelled:
      return "cancelled";
    case StopReason::kNoVariables:
      return "no-variables";
  }
  return "unknown";
}

int Optimizer::addNode(const Pose2& initial_pose) {
  poses_.push_back(initial_pose);
  fixed_.push_back(0);
  if (variables_valid_ && used_variables_ < num_variables_) {
    // A reserved slot: numbering, pattern and factor stay (updateFactor() folds the node in).
    variable_of_node_.push_back(used_variables_++);
  } else {
    variables_valid_ = false;
    pattern_valid_ = false;
  }
  return numNodes() - 1;
}

int Optimizer::addConstraint(int from, int to, const Pose2& measurement,
                             const Eigen::Matrix3d& information, bool active) {
  if (from < 0 || to < 0 || from >= numNodes() || to >= numNodes() || from == to) {
    throw std::invalid_argument("Optimizer::addConstraint: bad node index");
  }
  constraints_.push_back(Constraint{from, to, measurement, information});
  active_.push_back(active ? 1 : 0);
  weight_.push_back(1.0);
  in_pattern_.push_back(0);
  ConstraintSlots slots;
  if (variables_valid_) {  // its variables, for gradients and rank updates before a new pattern
    slots.from_var = variable_of_node_[static_cast<std::size_t>(from)];
    slots.to_var = variable_of_node_[static_cast<std::size_t>(to)];
  }
  slots_.push_back(slots);
  return numConstraints() - 1;
}

void Optimizer::setFixed(int node, bool fixed) {
  if (static_cast<bool>(fixed_[static_cast<std::size_t>(node)]) == fixed) return;
  covariance_valid_ = false;
  fixed_[static_cast<std::size_t>(node)] = fixed ? 1 : 0;
  variables_valid_ = false;
  pattern_valid_ = false;
}

void Optimizer::setPoses(const std::vector<Pose2>& poses) {
  if (poses.size() != poses_.size()) throw std::invalid_argument("Optimizer::setPoses: wrong size");
  poses_ = poses;
}

double Optimizer::constraintChi2(int constraint) const {
  const Constraint& c = constraints_[static_cast<std::size_t>(constraint)];
  const Eigen::Vector3d e = edgeError(poses_[static_cast<std::size_t>(c.from)],
                                      poses_[static_cast<std::size_t>(c.to)], c.measurement);
  return e.dot(c.information * e);
}

double Optimizer::chi2() const {
  double sum = 0.0;
  for (int k = 0; k < numConstraints(); ++k) {
    if (active_[static_cast<std::size_t>(k)]) sum += constraintChi2(k);
  }
  return sum;
}

double Optimizer::weightedChi2() const {
  double sum = 0.0;
  for (int k = 0; k < numConstraints(); ++k) {
    if (active_[static_cast<std::size_t>(k)])
      sum += weight_[static_cast<std::size_t>(k)] * constraintChi2(k);
  }
  return sum;
}

void Optimizer::prepareStructure() {
  if (!variables_valid_) {
    const bool any_fixed = std::any_of(fixed_.begin(), fixed_.end(), [](char f) { return f; });
    variable_of_node_.assign(poses_.size(), -1);
    used_variables_ = 0;
    for (std::size_t n = 0; n < poses_.size(); ++n) {
      const bool fixed = any_fixed ? fixed_[n] != 0 : n == 0;  // default gauge: node 0
      if (!fixed) variable_of_node_[n] = used_variables_++;
    }
    num_variables_ = used_variables_ + reservedSlots();
    variables_valid_ = true;
    pattern_valid_ = false;
    factor_valid_ = false;
  }
  if (pattern_valid_) {
    // Keep the pattern while it covers every active constraint and is not mostly dead weight.
    int active_count = 0;
    for (std::size_t k = 0; k < constraints_.size(); ++k) {
      if (!active_[k]) continue;
      ++active_count;
      if (!in_pattern_[k]) {
        pattern_valid_ = false;
        break;
      }
    }
    // Switched-off constraints still cost fill-in; long-range outliers cost a lot of it, so a
    // pattern more than 10% dead is rebuilt (the ordering costs less than one bloated factor).
    if (pattern_size_ - active_count > std::max(16, active_count / 10)) pattern_valid_ = false;
  }
  // A stale pattern is rebuilt by the next assembly of H (a run starting from a rank-updated
  // factor may need none).
}

void Optimizer::rebuildPattern() {
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(constraints_.size());
  pattern_size_ = 0;
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    in_pattern_[k] = active_[k];
    if (!active_[k]) continue;
    ++pattern_size_;
    const int a = variable_of_node_[static_cast<std::size_t>(constraints_[k].from)];
    const int b = variable_of_node_[static_cast<std::size_t>(constraints_[k].to)];
    if (a >= 0 && b >= 0) pairs.emplace_back(a, b);
  }
  // Variables are numbered in a fill-reducing order of the nodes, so that H is assembled
  // already permuted and CHOLMOD factors it as it is. Nodes that took reserved slots are ordered
  // with the rest; a fresh reserve follows them.
  const std::vector<int> order = blockOrdering(used_variables_, pairs);
  num_variables_ = used_variables_ + reservedSlots();
  std::vector<int> position(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    position[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  }
  for (int& v : variable_of_node_) {
    if (v >= 0) v = position[static_cast<std::size_t>(v)];
  }
  for (auto& [a, b] : pairs) {
    a = position[static_cast<std::size_t>(a)];
    b = position[static_cast<std::size_t>(b)];
  }
  hessian_.build(num_variables_, pairs);
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    ConstraintSlots& s = slots_[k];
    s.from_var = variable_of_node_[static_cast<std::size_t>(constraints_[k].from)];
    s.to_var = variable_of_node_[static_cast<std::size_t>(constraints_[k].to)];
    if (in_pattern_[k] && s.from_var >= 0 && s.to_var >= 0) {
      s.off_diagonal =
          hessian_.offDiagonalSlots(std::min(s.from_var, s.to_var), std::max(s.from_var, s.to_var));
    }
  }
  // A factor that takes rank updates stays simplicial: each update would convert a supernodal
  // one, and the next factorization analyze the pattern again. Its fresh factorizations cost
  // 1.8x the supernodal ones on City10000, yet with reserved slots (most new nodes join by
  // updates) incremental City10000 + 1000 random seeds 1/2/3 has 103/78/90 candidates over
  // 50 ms instead of 132/112/83 with CHOLMOD's choice (without slots: within the noise).
  solver_.analyze(
      hessian_.matrix(), true,
      params_.factor_updates ? SparseSolver::Kind::kSimplicial : SparseSolver::Kind::kAuto);
  pattern_valid_ = true;
  factor_valid_ = false;
  covariance_valid_ = false;
}

void Optimizer::chooseAnchors() {
  UnionFind sets(poses_.size());
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    if (active_[k])
      sets.unite(static_cast<std::size_t>(constraints_[k].from),
                 static_cast<std::size_t>(constraints_[k].to));
  }
  std::vector<char> held(poses_.size(), 0);
  for (std::size_t n = 0; n < poses_.size(); ++n) {
    if (variable_of_node_[n] < 0) held[sets.find(n)] = 1;
  }
  anchors_.clear();
  anchor_poses_.clear();
  for (std::size_t n = 0; n < poses_.size(); ++n) {
    const std::size_t root = sets.find(n);
    if (held[root]) continue;
    held[root] = 1;  // n is the first node of an unanchored component
    anchors_.push_back(static_cast<int>(n));
    anchor_poses_.push_back(poses_[n]);
  }
}

double Optimizer::assemble(bool with_hessian) {
  if (with_hessian) {
    if (!pattern_valid_) rebuildPattern();  // renumbers the variables: gradient_ follows below
    hessian_.setZero();
  }
  gradient_.setZero(3 * num_variables_);
  double chi2_sum = 0.0;
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    if (!active_[k]) continue;
    const Constraint& c = constraints_[k];
    const ConstraintSlots& s = slots_[k];
    const EdgeLinearization lin =
        linearizeEdge(poses_[static_cast<std::size_t>(c.from)],
                      poses_[static_cast<std::size_t>(c.to)], c.measurement);
    const double w = weight_[k];
    const Eigen::Matrix3d omega = w == 1.0 ? c.information : Eigen::Matrix3d(w * c.information);
    const Eigen::Vector3d omega_e = omega * lin.error;
    chi2_sum += lin.error.dot(omega_e);
    if (!with_hessian) {
      if (s.from_var >= 0) gradient_.segment<3>(3 * s.from_var) += lin.J_from.transpose() * omega_e;
      if (s.to_var >= 0) gradient_.segment<3>(3 * s.to_var) += lin.J_to.transpose() * omega_e;
      continue;
    }
    const Eigen::Matrix3d JfT_omega = lin.J_from.transpose() * omega;
    const Eigen::Matrix3d JtT_omega = lin.J_to.transpose() * omega;
    if (s.from_var >= 0) {
      hessian_.addDiagonal(s.from_var, JfT_omega * lin.J_from);
      gradient_.segment<3>(3 * s.from_var) += lin.J_from.transpose() * omega_e;
    }
    if (s.to_var >= 0) {
      hessian_.addDiagonal(s.to_var, JtT_omega * lin.J_to);
      gradient_.segment<3>(3 * s.to_var) += lin.J_to.transpose() * omega_e;
    }
    if (s.from_var >= 0 && s.to_var >= 0) {
      if (s.from_var < s.to_var) {
        hessian_.addOffDiagonal(s.off_diagonal, JfT_omega * lin.J_to);
      } else {
        hessian_.addOffDiagonal(s.off_diagonal, JtT_omega * lin.J_from);
      }
    }
  }
  const double anchor = params_.anchor_information;
  for (std::size_t a = 0; a < anchors_.size(); ++a) {
    const int n = anchors_[a];
    const int v = variable_of_node_[static_cast<std::size_t>(n)];
    Eigen::Vector3d d = poses_[static_cast<std::size_t>(n)] - anchor_poses_[a];
    d.z() = normalizeAngle(d.z());
    if (with_hessian) hessian_.addDiagonal(v, anchor * Eigen::Matrix3d::Identity());
    gradient_.segment<3>(3 * v) += anchor * d;
  }
  if (with_hessian) {
    for (int v = used_variables_; v < num_variables_; ++v)
      hessian_.addDiagonal(v, Eigen::Matrix3d::Identity());  // free slots: step 0
  }
  return chi2_sum;
}

void Optimizer::applyStep(const Eigen::VectorXd& step) {
  for (std::size_t n = 0; n < poses_.size(); ++n) {
    const int v = variable_of_node_[n];
    if (v < 0) continue;
    poses_[n] += step.segment<3>(3 * v);
    poses_[n].z() = normalizeAngle(poses_[n].z());
  }
}

namespace {

double secondsSince(std::chrono::steady_clock::time_point& since) {
  const auto now = std::chrono::steady_clock::now();
  const double sec = std::chrono::duration<double>(now - since).count();
  since = now;
  return sec;
}

}  // namespace

OptimizationResult Optimizer::optimize() {
  const auto start = std::chrono::steady_clock::now();
  OptimizationResult result;
  auto clock = start;
  prepareStructure();
  chooseAnchors();
  result.timing.structure_sec += secondsSince(clock);

  const bool gauss_newton = params_.method == OptimizerParams::Method::kGaussNewton;
  const bool updated =
      gauss_newton && params_.factor_updates && used_variables_ > 0 && updateFactor(result);
  result.timing.factorize_sec += secondsSince(clock);
  double chi2_now = assemble(!updated);
  result.timing.assemble_sec += secondsSince(clock);
  result.initial_chi2 = chi2_now;
  result.stop_reason = StopReason::kMaxIterations;

  if (used_variables_ == 0) {
    result.stop_reason = StopReason::kNoVariables;
  } else if (!std::isfinite(chi2_now)) {
    result.stop_reason = StopReason::kDiverged;  // no step can be judged from here
  } else if (gauss_newton) {
    gaussNewton(result, chi2_now, updated, clock);
  } else {
    levenbergMarquardt(result, chi2_now, clock);
  }

  result.final_chi2 = chi2_now;
  if (params_.compute_constraint_chi2) {
    result.constraint_chi2.resize(constraints_.size());
    for (int k = 0; k < numConstraints(); ++k) {
      result.constraint_chi2[static_cast<std::size_t>(k)] = constraintChi2(k);
    }
  }
  result.time_sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void Optimizer::rememberFactoredState() {
  factor_valid_ = true;
  factored_active_ = active_;
  factored_weight_ = weight_;
  factored_anchors_ = anchors_;
  factored_nodes_ = numNodes();
  factored_constraints_ = numConstraints();
  updates_since_factorization_ = 0;
}

bool Optimizer::updateFactor(OptimizationResult& result) {
  if (!factor_valid_ || anchors_ != factored_anchors_) return false;
  std::vector<int> added, removed;
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    const bool was = k < factored_active_.size() && factored_active_[k];
    if (was && active_[k] && weight_[k] != factored_weight_[k]) return false;
    if (!was && active_[k]) added.push_back(static_cast<int>(k));
    if (was && !active_[k]) removed.push_back(static_cast<int>(k));
  }
  const int switched = static_cast<int>(added.size() + removed.size());
  if (updates_since_factorization_ + switched > params_.max_factor_updates) return false;
  // Nodes added since sit on reserved slots (a renumbering would have dropped the factor); the
  // unchanged anchors say each hangs from the factored graph by the constraints added above.
  std::vector<int> taken;
  for (int n = factored_nodes_; n < numNodes(); ++n)
    taken.push_back(variable_of_node_[static_cast<std::size_t>(n)]);
  // Each constraint's share of H, J^T (w Omega) J, is C C^T with C = J^T chol(w Omega), linearized
  // at the current poses (the factor's own linearization point is older: chord steps). A taken
  // slot's identity block is E E^T with E its unit columns, appended after the constraints.
  auto columns = [&](const std::vector<int>& list, const std::vector<int>& slots) {
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(18 * list.size() + 3 * slots.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      const auto k = static_cast<std::size_t>(list[i]);
      const Constraint& c = constraints_[k];
      const EdgeLinearization lin =
          linearizeEdge(poses_[static_cast<std::size_t>(c.from)],
                        poses_[static_cast<std::size_t>(c.to)], c.measurement);
      const Eigen::Matrix3d root = Eigen::Matrix3d((weight_[k] * c.information).llt().matrixL());
      const Eigen::Matrix3d from = lin.J_from.transpose() * root;
      const Eigen::Matrix3d to = lin.J_to.transpose() * root;
      const int col = 3 * static_cast<int>(i);
      for (int r = 0; r < 3; ++r) {
        for (int q = 0; q < 3; ++q) {
          if (slots_[k].from_var >= 0)
            entries.emplace_back(3 * slots_[k].from_var + r, col + q, from(r, q));
          if (slots_[k].to_var >= 0)
            entries.emplace_back(3 * slots_[k].to_var + r, col + q, to(r, q));
        }
      }
    }
    const int first_slot_column = 3 * static_cast<int>(list.size());
    for (std::size_t i = 0; i < slots.size(); ++i) {
      for (int r = 0; r < 3; ++r)
        entries.emplace_back(3 * slots[i] + r, first_slot_column + 3 * static_cast<int>(i) + r,
                             1.0);
    }
    SparseSolver::Matrix C(3 * num_variables_,
                           first_slot_column + 3 * static_cast<Eigen::Index>(slots.size()));
    C.setFromTriplets(entries.begin(), entries.end());
    C.makeCompressed();
    return C;
  };
  // Additions first: the new nodes' constraints make their slots definite without the identity.
  if ((!added.empty() && !solver_.update(columns(added, {}), true)) ||
      ((!removed.empty() || !taken.empty()) && !solver_.update(columns(removed, taken), false))) {
    factor_valid_ = false;
    return false;
  }
  result.factor_updates = switched;
  updates_since_factorization_ += switched;
  factored_nodes_ = numNodes();
  factored_constraints_ = numConstraints();
  factored_active_ = active_;
  factored_weight_ = weight_;
  return true;
}

void Optimizer::gaussNewton(OptimizationResult& result, double& chi2_now, bool start_with_factor,
                            std::chrono::steady_clock::time_point& clock) {
  auto& timing = result.timing;
  // An updated factor serves covariance() too, linearized partly at earlier poses.
  covariance_valid_ = start_with_factor;
  // Near the minimum H hardly changes between steps, so the last factorization is reused
  // (chord steps: new gradient, old factor) while that still shrinks the chi2 decrease fast.
  // The fixed point is the same (gradient = 0); a chord step that does not lower chi2 is
  // undone and followed by a fresh factorization. A full step that raises chi2 (far from the
  // minimum, e.g. with gross outliers switched on) is undone and Levenberg-Marquardt takes over.
  // A factor brought up to date by rank updates starts the run in the same (chord) mode.
  bool reuse_factor = start_with_factor;
  double last_decrease = start_with_factor ? std::numeric_limits<double>::infinity() : 0.0;
  // H is assembled only where a factorization may follow; chord steps need the gradient alone
  // (optimize() assembled H unless it starts from an updated factor).
  bool hessian_current = !start_with_factor;
  while (result.iterations < params_.max_iterations) {
    if (cancelled()) {
      result.stop_reason = StopReason::kCancelled;
      return;
    }
    if (!reuse_factor) {
      if (!hessian_current) {
        assemble();
        timing.assemble_sec += secondsSince(clock);
      }
      const bool factorized = solver_.factorize(hessian_.matrix());
      timing.factorize_sec += secondsSince(clock);
      ++result.factorizations;
      covariance_valid_ = factorized;
      factor_valid_ = false;
      if (!factorized) {
        result.stop_reason = StopReason::kSingular;
        return;
      }
      rememberFactoredState();
    }
    const Eigen::VectorXd step = solver_.solve(Eigen::VectorXd(-gradient_));
    // The decrease the quadratic model still expects (half the Newton decrement, with this
    // factor's H). Below the tolerance the run has converged: near the minimum a stale factor's
    // step overshoots by about as much as it could gain, and would cost a fresh factorization.
    if (-0.5 * gradient_.dot(step) <= params_.relative_tolerance * chi2_now) {
      timing.solve_sec += secondsSince(clock);
      result.stop_reason = StopReason::kConverged;
      return;
    }
    const std::vector<Pose2> saved = poses_;
    applyStep(step);
    timing.solve_sec += secondsSince(clock);
    // The gradient alone: H is assembled only when a fresh factorization follows (most steps
    // after a fresh one are chord steps, which would not use it).
    hessian_current = false;
    const double chi2_next = assemble(false);
    timing.assemble_sec += secondsSince(clock);
    const double decrease = chi2_now - chi2_next;
    // A step to a non-finite chi2 is never taken.
    if (!std::isfinite(chi2_next) ||
        (!(decrease > 0.0) &&
         (reuse_factor || decrease < -params_.relative_tolerance * chi2_now))) {
      poses_ = saved;
      chi2_now = assemble();
      hessian_current = true;
      timing.assemble_sec += secondsSince(clock);
      if (reuse_factor) {
        reuse_factor = false;  // the stale factor overshot: refactorize here
        continue;
      }
      levenbergMarquardt(result, chi2_now, clock);
      return;
    }
    ++result.iterations;
    const bool small_decrease = decrease <= params_.relative_tolerance * chi2_now;
    const bool small_step = step.lpNorm<Eigen::Infinity>() <= params_.step_tolerance;
    reuse_factor = params_.reuse_factorization && decrease > 0.0 &&
                   (reuse_factor ? decrease < 0.5 * last_decrease : decrease < 0.3 * chi2_now);
    last_decrease = decrease;
    chi2_now = chi2_next;
    if (small_step || small_decrease) {
      result.stop_reason = StopReason::kConverged;
      return;
    }
  }
}

void Optimizer::levenbergMarquardt(OptimizationResult& result, double& chi2_now,
                                   std::chrono::steady_clock::time_point& clock) {
  auto& timing = result.timing;
  covariance_valid_ = false;  // damped factors describe no covariance
  factor_valid_ = false;      // nor an undamped H to update
  // Marquardt's scaling: damp each variable in proportion to its own curvature, which copes
  // with the mix of metres and radians and with far-off initial guesses (City10000, ringCity).
  Eigen::VectorXd diagonal = hessian_.diagonal();
  double lambda = params_.lm_tau;
  double nu = 2.0;
  int attempts = 0;
  while (result.iterations < params_.max_iterations) {
    if (cancelled()) {
      result.stop_reason = StopReason::kCancelled;
      return;
    }
    if (++attempts > 10 * params_.max_iterations + 50 || lambda > 1e30) {
      result.stop_reason = StopReason::kDiverged;
      return;
    }
    const Eigen::VectorXd damping = lambda * diagonal.cwiseMax(1e-12);
    hessian_.setDiagonal(diagonal + damping);
    const bool factorized = solver_.factorize(hessian_.matrix());
    hessian_.setDiagonal(diagonal);
    timing.factorize_sec += secondsSince(clock);
    ++result.factorizations;
    if (!factorized) {
      lambda *= nu;
      nu *= 2.0;
      continue;
    }
    const Eigen::VectorXd step = solver_.solve(Eigen::VectorXd(-gradient_));
    const std::vector<Pose2> saved = poses_;
    applyStep(step);
    const double chi2_next = weightedChi2();
    timing.solve_sec += secondsSince(clock);
    const double predicted = step.dot(damping.cwiseProduct(step) - gradient_);
    const double rho = (chi2_now - chi2_next) / std::max(predicted, 1e-300);
    // Also done when even the quadratic model sees nothing left to gain: near the minimum rho
    // is a ratio of rounding errors.
    const bool small_step = step.lpNorm<Eigen::Infinity>() <= params_.step_tolerance ||
                            predicted <= params_.relative_tolerance * chi2_now;
    if (rho > 0.0 && std::isfinite(chi2_next)) {
      ++result.iterations;
      // A small decrease means convergence only when the quadratic model predicted it well;
      // a heavily damped step also decreases chi2 little, without being near the minimum.
      const bool small_decrease =
          chi2_now - chi2_next <= params_.relative_tolerance * chi2_now && rho > 0.25;
      chi2_now = assemble();
      diagonal = hessian_.diagonal();
      timing.assemble_sec += secondsSince(clock);
      lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
      if (small_decrease || small_step) {
        result.stop_reason = StopReason::kConverged;
        return;
      }
    } else {
      poses_ = saved;
      if (small_step) {
        result.stop_reason = StopReason::kConverged;
        return;
      }
      lambda *= nu;
      nu *= 2.0;
    }
  }
}

bool Optimizer::nodesAddedAsTree(std::vector<int>& parent) const {
  parent.assign(static_cast<std::size_t>(numNodes() - factored_nodes_), -1);
  for (int k = factored_constraints_; k < numConstraints(); ++k) {
    if (!active_[static_cast<std::size_t>(k)]) continue;
    const int newer = std::max(from(k), to(k)) - factored_nodes_;
    if (newer < 0 || parent[static_cast<std::size_t>(newer)] >= 0) return false;
    parent[static_cast<std::size_t>(newer)] = k;
  }
  // A node without one starts a new session, held only by its weak anchor.
  return std::find(parent.begin(), parent.end(), -1) == parent.end();
}

Eigen::MatrixXd Optimizer::factorCovariance(const std::vector<int>& nodes) const {
  // Fixed nodes have no variable and zero covariance.
  std::vector<int> rows, at;
  for (std::size_t a = 0; a < nodes.size(); ++a) {
    const int v = variable_of_node_[static_cast<std::size_t>(nodes[a])];
    if (v < 0) continue;
    for (int r = 0; r < 3; ++r) {
      rows.push_back(3 * v + r);
      at.push_back(3 * static_cast<int>(a) + r);
    }
  }
  const Eigen::MatrixXd inverse = solver_.inverseSubmatrix(rows);
  const auto m = static_cast<Eigen::Index>(nodes.size());
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(3 * m, 3 * m);
  for (std::size_t a = 0; a < at.size(); ++a) {
    for (std::size_t b = 0; b < at.size(); ++b) {
      out(at[a], at[b]) = inverse(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
    }
  }
  return out;
}

Eigen::MatrixXd Optimizer::covariance(const std::vector<int>& nodes) const {
  const auto m = static_cast<Eigen::Index>(nodes.size());
  std::vector<int> parent;
  if (!covariance_valid_ || !nodesAddedAsTree(parent)) return Eigen::MatrixXd::Zero(3 * m, 3 * m);
  auto other_end = [&](int constraint, int node) {
    return from(constraint) == node ? to(constraint) : from(constraint);
  };
  // The tree nodes needed: the requested ones and their ancestors, down to factored nodes.
  const auto added = parent.size();
  std::vector<char> needed(added, 0), requested(added, 0);
  std::vector<int> pending_children(added, 0);
  std::vector<int> kept;  // nodes whose joint covariance `sigma` holds, in its order
  for (int n : nodes) {
    if (n >= factored_nodes_) {
      needed[static_cast<std::size_t>(n - factored_nodes_)] = 1;
      requested[static_cast<std::size_t>(n - factored_nodes_)] = 1;
    } else {
      kept.push_back(n);
    }
  }
  for (std::size_t k = added; k-- > 0;) {
    if (!needed[k]) continue;
    const int p = other_end(parent[k], factored_nodes_ + static_cast<int>(k));
    if (p >= factored_nodes_) {
      needed[static_cast<std::size_t>(p - factored_nodes_)] = 1;
      ++pending_children[static_cast<std::size_t>(p - factored_nodes_)];
    } else {
      kept.push_back(p);
    }
  }
  std::sort(kept.begin(), kept.end());
  kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
  Eigen::MatrixXd sigma = factorCovariance(kept);

  auto position = [&](int node) {
    return 3 * static_cast<Eigen::Index>(std::find(kept.begin(), kept.end(), node) - kept.begin());
  };
  // Down the tree: a node hanging from p by e(x_p, x_n) = J_p dx_p + J_n dx_n + noise has
  // dx_n = A dx_p + w, A = -J_n^-1 J_p, cov(w) = J_n^-1 (w Omega)^-1 J_n^-T.
  for (std::size_t k = 0; k < added; ++k) {
    if (!needed[k]) continue;
    const int node = factored_nodes_ + static_cast<int>(k);
    const auto c = static_cast<std::size_t>(parent[k]);
    const int p = other_end(parent[k], node);
    const Constraint& con = constraints_[c];
    const EdgeLinearization lin =
        linearizeEdge(poses_[static_cast<std::size_t>(con.from)],
                      poses_[static_cast<std::size_t>(con.to)], con.measurement);
    const bool node_is_to = con.to == node;
    const Eigen::Matrix3d J_node_inverse = (node_is_to ? lin.J_to : lin.J_from).inverse();
    const Eigen::Matrix3d A = -J_node_inverse * (node_is_to ? lin.J_from : lin.J_to);
    const Eigen::Matrix3d Q =
        J_node_inverse * (weight_[c] * con.information).inverse() * J_node_inverse.transpose();
    const Eigen::Index at = position(p), size = sigma.rows();
    const Eigen::MatrixXd cross = A * sigma.middleRows(at, 3);  // 3 x size
    const Eigen::Matrix3d own = A * sigma.block<3, 3>(at, at) * A.transpose() + Q;
    sigma.conservativeResize(size + 3, size + 3);
    sigma.bottomLeftCorner(3, size) = cross;
    sigma.topRightCorner(size, 3) = cross.transpose();
    sigma.bottomRightCorner<3, 3>() = 0.5 * (own + own.transpose());
    kept.push_back(node);
    // A parent no longer needed leaves sigma, which stays as small as the request.
    if (p >= factored_nodes_) {
      const auto q = static_cast<std::size_t>(p - factored_nodes_);
      if (--pending_children[q] == 0 && !requested[q]) {
        std::vector<Eigen::Index> rows;
        for (Eigen::Index r = 0; r < sigma.rows(); ++r) {
          if (r / 3 != at / 3) rows.push_back(r);
        }
        sigma = Eigen::MatrixXd(sigma(rows, rows));
        kept.erase(kept.begin() + at / 3);
      }
    }
  }

  Eigen::MatrixXd out(3 * m, 3 * m);
  for (Eigen::Index a = 0; a < m; ++a) {
    for (Eigen::Index b = 0; b < m; ++b) {
      out.block<3, 3>(3 * a, 3 * b) =
          sigma.block<3, 3>(position(nodes[static_cast<std::size_t>(a)]),
                            position(nodes[static_cast<std::size_t>(b)]));
    }
  }
  return out;
}

Optimizer makeOptimizer(const PoseGraph& graph, const OptimizerParams& params) {
  Optimizer optimizer(params);
  std::unordered_map<PoseGraph::NodeId, int> index_of;
  for (PoseGraph::NodeId id : graph.nodeIds())
    index_of.emplace(id, optimizer.addNode(graph.pose(id)));
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const auto& e = graph.edge(k);
    optimizer.addConstraint(index_of.at(e.from), index_of.at(e.to), graph.measurement(k),
                            graph.information(k));
  }
  return optimizer;
}

void copyPosesToGraph(const Optimizer& optimizer, PoseGraph& graph) {
  const auto ids = graph.nodeIds();
  if (ids.size() != optimizer.poses().size()) {
    throw std::invalid_argument("copyPosesToGraph: optimizer and graph differ in node count");
  }
  for (std::size_t k = 0; k < ids.size(); ++k) graph.setPose(ids[k], optimizer.poses()[k]);
}

}  // namespace rrr_graphslam::core
