#include "rrr_graphslam/core/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "rrr_graphslam/core/stopwatch.h"
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

int Optimizer::addDenseFactor(const std::vector<int>& nodes, const DenseFactor& factor) {
  const std::string problem = denseFactorProblem(factor);
  if (!problem.empty()) throw std::invalid_argument("Optimizer::addDenseFactor: " + problem);
  if (nodes.size() != factor.nodes.size()) {
    throw std::invalid_argument("Optimizer::addDenseFactor: " + std::to_string(nodes.size()) +
                                " nodes for a factor over " + std::to_string(factor.nodes.size()));
  }
  std::vector<int> sorted = nodes;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.front() < 0 || sorted.back() >= numNodes() ||
      std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw std::invalid_argument("Optimizer::addDenseFactor: bad node index");
  }
  dense_.push_back(Dense{factor, nodes, {}, {}});
  // A new term of H: a new pattern, and no factor or covariance stands for the graph any more.
  pattern_valid_ = false;
  factor_valid_ = false;
  covariance_valid_ = false;
  return numDenseFactors() - 1;
}

namespace {

// The poses of a dense factor's nodes, in its order.
std::vector<Pose2> posesOf(const std::vector<Pose2>& poses, const std::vector<int>& nodes) {
  std::vector<Pose2> at;
  at.reserve(nodes.size());
  for (int n : nodes) at.push_back(poses[static_cast<std::size_t>(n)]);
  return at;
}

}  // namespace

double Optimizer::denseFactorChi2(int factor) const {
  const Dense& d = dense_.at(static_cast<std::size_t>(factor));
  return core::denseFactorChi2(d.factor, posesOf(poses_, d.nodes));
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
  for (int f = 0; f < numDenseFactors(); ++f) sum += denseFactorChi2(f);
  return sum;
}

double Optimizer::weightedChi2() const {
  double sum = 0.0;
  for (int k = 0; k < numConstraints(); ++k) {
    if (active_[static_cast<std::size_t>(k)])
      sum += weight_[static_cast<std::size_t>(k)] * constraintChi2(k);
  }
  for (int f = 0; f < numDenseFactors(); ++f) sum += denseFactorChi2(f);
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
  for (const Dense& d : dense_) {  // a dense factor couples every pair of its nodes
    for (std::size_t i = 0; i < d.nodes.size(); ++i) {
      const int a = variable_of_node_[static_cast<std::size_t>(d.nodes[i])];
      if (a < 0) continue;
      for (std::size_t j = i + 1; j < d.nodes.size(); ++j) {
        const int b = variable_of_node_[static_cast<std::size_t>(d.nodes[j])];
        if (b >= 0) pairs.emplace_back(a, b);
      }
    }
  }
  // Variables are numbered in a fill-reducing order of the nodes, so that H is assembled
  // already permuted and CHOLMOD factors it as it is. Nodes that took reserved slots are ordered
  // with the rest; a fresh reserve follows them.
  const std::vector<int> order = blockOrdering(used_variables_, pairs).order;
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
  for (Dense& d : dense_) {
    d.vars.clear();
    for (int n : d.nodes) d.vars.push_back(variable_of_node_[static_cast<std::size_t>(n)]);
    d.pair_slots.clear();
    for (std::size_t i = 0; i < d.vars.size(); ++i) {
      for (std::size_t j = i + 1; j < d.vars.size(); ++j) {
        const int a = d.vars[i], b = d.vars[j];
        if (a >= 0 && b >= 0) {
          d.pair_slots.push_back(hessian_.offDiagonalSlots(std::min(a, b), std::max(a, b)));
        }
      }
    }
  }
  // A factor that takes rank updates stays simplicial: each update would convert a supernodal
  // one, and the next factorization analyze the pattern again. Its fresh factorizations cost
  // 1.8x the supernodal ones on City10000, yet with reserved slots (most new nodes join by
  // updates) incremental City10000 + 1000 random seeds 1/2/3 has 103/78/90 candidates over
  // 50 ms instead of 132/112/83 with CHOLMOD's choice (without slots: within the noise).
  // Nothing to analyze without variables (a graph of fixed nodes only): CHOLMOD would complain.
  if (num_variables_ > 0) {
    solver_.analyze(
        hessian_.matrix(), true,
        params_.factor_updates ? SparseSolver::Kind::kSimplicial : SparseSolver::Kind::kAuto);
  }
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
  for (const Dense& d : dense_) {
    for (int n : d.nodes) {
      sets.unite(static_cast<std::size_t>(d.nodes.front()), static_cast<std::size_t>(n));
    }
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
  chi2_sum += assembleDense(with_hessian);
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

double Optimizer::assembleDense(bool with_hessian) {
  double chi2_sum = 0.0;
  for (const Dense& d : dense_) {
    const DenseFactorLinearization lin = linearize(d.factor, posesOf(poses_, d.nodes));
    chi2_sum += lin.chi2;
    std::size_t pair = 0;
    for (std::size_t i = 0; i < d.nodes.size(); ++i) {
      const int a = d.vars[i];
      const auto row = static_cast<Eigen::Index>(3 * i);
      if (a >= 0) gradient_.segment<3>(3 * a) += lin.gradient.segment<3>(row);
      if (!with_hessian) continue;
      if (a >= 0) hessian_.addDiagonal(a, lin.information.block<3, 3>(row, row));
      for (std::size_t j = i + 1; j < d.nodes.size(); ++j) {
        const int b = d.vars[j];
        if (a < 0 || b < 0) continue;
        const Eigen::Matrix3d block =
            lin.information.block<3, 3>(row, static_cast<Eigen::Index>(3 * j));
        hessian_.addOffDiagonal(d.pair_slots[pair++],
                                a < b ? block : Eigen::Matrix3d(block.transpose()));
      }
    }
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

OptimizationResult Optimizer::optimize() {
  const auto start = std::chrono::steady_clock::now();
  OptimizationResult result;
  auto clock = start;
  prepareStructure();
  chooseAnchors();
  result.timing.structure_sec += lap(clock);

  const bool gauss_newton = params_.method == OptimizerParams::Method::kGaussNewton;
  const bool updated =
      gauss_newton && params_.factor_updates && used_variables_ > 0 && updateFactor(result);
  result.timing.factorize_sec += lap(clock);
  double chi2_now = assemble(!updated);
  result.timing.assemble_sec += lap(clock);
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
  result.time_sec = secondsSince(start);
  return result;
}

OptimizationResult Optimizer::optimize(const OptimizationRequest& request) {
  if (request.start != nullptr) setPoses(*request.start);
  struct Restore {
    OptimizerParams& params;
    OptimizerParams saved;
    ~Restore() { params = saved; }
  } restore{params_, params_};
  if (request.method) params_.method = *request.method;
  if (request.max_iterations) params_.max_iterations = *request.max_iterations;
  if (request.relative_tolerance) params_.relative_tolerance = *request.relative_tolerance;
  return optimize();
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
  for (const DenseFactor& f : graph.denseFactors()) {
    std::vector<int> nodes;
    for (PoseGraph::NodeId id : f.nodes) nodes.push_back(index_of.at(id));
    optimizer.addDenseFactor(nodes, f);
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
