#pragma once
// Sparse Gauss-Newton / Levenberg-Marquardt for SE(2) pose graphs, solved with CHOLMOD.
//
// Built for repeated use (RRR runs thousands of optimizations on one graph): constraints are
// switched on and off instead of rebuilding the problem, every call starts from the current
// poses (warm start), and the sparsity pattern with its fill-reducing ordering is kept as long
// as it covers the active constraints. Switching a constraint off keeps the pattern; switching
// on one that is not in it rebuilds it once. With factor updates, nodes added later take
// variable slots reserved at the end of the ordering and join the factor by rank updates.
//
// Gauge: the fixed nodes (node 0 unless others are fixed) are not variables. A connected part
// of the active graph without a fixed node (another session, or a node without active
// constraints) is held by a weak prior on its first node, so it stays solvable without
// biasing its shape.
//
// chi2 is the sum over active constraints of e^T * Omega * e, with e as in g2o's EdgeSE2.
// Gauss-Newton hands over to Levenberg-Marquardt when a full step raises chi2.
// Not thread-safe: one thread per Optimizer.

#include <atomic>
#include <chrono>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "rrr_graphslam/core/block_hessian.h"
#include "rrr_graphslam/core/dense_factor.h"
#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/core/sparse_solver.h"

namespace rrr_graphslam::core {

struct OptimizerParams {
  enum class Method { kGaussNewton, kLevenbergMarquardt };
  Method method = Method::kGaussNewton;  ///< default: Gauss-Newton
  int max_iterations = 50;               ///< accepted steps; default 50
  /// Converged when chi2 drops by less than this fraction in one step; default 1e-6
  /// (chi2 is then within ~1e-6 of its minimum on the vertigo graphs, far below test noise).
  double relative_tolerance = 1e-6;
  /// Converged when no state entry moves by more than this (m or rad); default 1e-9.
  double step_tolerance = 1e-9;
  /// LM: initial damping factor on diag(H) (Marquardt scaling); default 1e-5.
  double lm_tau = 1e-5;
  /// Information (per axis) of the weak prior that anchors unanchored components; default 1e-6.
  double anchor_information = 1e-6;
  /// GN: reuse the last factorization near the minimum (see optimize()); default true.
  bool reuse_factorization = true;
  /// GN: start from the last factorization, brought up to date by CHOLMOD rank updates for the
  /// constraints switched on or off since (at most max_factor_updates of them since the last
  /// fresh factorization), instead of a fresh factorization; the steps are then chord steps, as
  /// near the minimum (see optimize()). Constraints new to the sparsity pattern are folded in
  /// too (the pattern is rebuilt at the next fresh factorization). covariance() then reads the
  /// updated factor: H with each constraint linearized where it was folded in. Default false
  /// (batch RRR wants each covariance fresh; incremental RRR turns it on).
  bool factor_updates = false;
  int max_factor_updates = 64;  ///< constraints switched since the factorization; default 64
  /// With factor_updates: variables kept free at the end of the fill-reducing order for nodes
  /// added later (identity blocks on H's diagonal, coupled to nothing). A new node takes the next
  /// one, so a growing graph keeps its ordering and factor: the node's constraints come in by a
  /// rank update and its slot's identity leaves by a downdate (the node's constraints count
  /// against max_factor_updates). Default 64; 0: a new node means a new pattern and a fresh
  /// factorization. With a simplicial factor (see rebuildPattern), City10000 + 1000 random,
  /// incremental, seeds 1/2/3: p99 54/61/57 -> 44/38/42 ms per candidate.
  int reserved_slots = 64;
  /// Fill OptimizationResult::constraint_chi2 for every constraint; default false.
  bool compute_constraint_chi2 = false;
};

/// Why optimize() stopped. Only kConverged (and kNoVariables) leave a minimum in poses(); every
/// caller handles the others deliberately (RRR: a chi2 test passed at the poses reached still
/// holds, since the minimum is lower; a failed one is conservative; rrr_optimize: an error).
enum class StopReason {
  kConverged,      ///< chi2 or step below tolerance
  kMaxIterations,  ///< max_iterations reached first
  kSingular,       ///< Gauss-Newton: the normal matrix is not positive definite
  kDiverged,       ///< chi2 not finite, or Levenberg-Marquardt's damping grew without a step
  kCancelled,      ///< the cancel flag (setCancelFlag) was raised
  kNoVariables,    ///< every node is fixed
};

std::string toString(StopReason reason);

/// What one optimize() call works on besides the active constraints: where it starts and, for this
/// call only, the method and limits (unset: params()'s).
struct OptimizationRequest {
  /// One pose per node; nullptr: the current poses (a warm start).
  const std::vector<Pose2>* start = nullptr;
  std::optional<OptimizerParams::Method> method;
  std::optional<int> max_iterations;
  std::optional<double> relative_tolerance;
};

/// A request to start from `poses` (which must outlive it), with params()'s method and limits.
inline OptimizationRequest startFrom(const std::vector<Pose2>& poses) {
  OptimizationRequest request;
  request.start = &poses;
  return request;
}

struct OptimizationResult {
  int iterations = 0;      ///< accepted steps
  int factorizations = 0;  ///< numeric Cholesky factorizations (GN reuses them near the end)
  int factor_updates = 0;  ///< constraints folded into the last factorization by rank updates
  double initial_chi2 = 0.0;
  double final_chi2 = 0.0;
  double time_sec = 0.0;
  StopReason stop_reason = StopReason::kConverged;
  /// At a minimum: converged (or nothing to optimize) with a finite chi2.
  bool converged() const {
    return (stop_reason == StopReason::kConverged || stop_reason == StopReason::kNoVariables) &&
           final_chi2 == final_chi2 && final_chi2 < std::numeric_limits<double>::infinity();
  }
  /// Per constraint (active or not) at the final poses, if compute_constraint_chi2.
  std::vector<double> constraint_chi2;
  /// Where time_sec went (seconds): pattern + ordering, building H, factorizations, solves.
  struct Timing {
    double structure_sec = 0.0;
    double assemble_sec = 0.0;
    double factorize_sec = 0.0;
    double solve_sec = 0.0;
  } timing;
};

class Optimizer {
 public:
  explicit Optimizer(const OptimizerParams& params = {}) : params_(params) {}

  OptimizerParams& params() { return params_; }
  const OptimizerParams& params() const { return params_; }

  /// Returns the new node's index (0, 1, 2, ...).
  int addNode(const Pose2& initial_pose);
  /// Returns the new constraint's index. `information` must be symmetric positive definite.
  int addConstraint(int from, int to, const Pose2& measurement, const Eigen::Matrix3d& information,
                    bool active = true);

  /// Adds a dense factor (dense_factor.h) over the optimizer's nodes `nodes` (the factor's order,
  /// root first; the factor's own node ids are not used). Always active and unweighted: it stands
  /// for trusted constraints that were marginalized. Its chi2 (offset included) counts in chi2(),
  /// weightedChi2() and the results'. Throws std::invalid_argument for a bad node index, a count
  /// that does not match the factor, or a factor with denseFactorProblem(). Returns its index.
  int addDenseFactor(const std::vector<int>& nodes, const DenseFactor& factor);
  int numDenseFactors() const { return static_cast<int>(dense_.size()); }
  const DenseFactor& denseFactor(int factor) const {
    return dense_.at(static_cast<std::size_t>(factor)).factor;
  }
  /// The optimizer's nodes of a dense factor, in the factor's order.
  const std::vector<int>& denseFactorNodes(int factor) const {
    return dense_.at(static_cast<std::size_t>(factor)).nodes;
  }
  /// The dense factor's chi2 at the current poses.
  double denseFactorChi2(int factor) const;

  void setActive(int constraint, bool active) {
    auto& a = active_[static_cast<std::size_t>(constraint)];
    if (static_cast<bool>(a) != active) covariance_valid_ = false;
    a = active ? 1 : 0;
  }
  /// Scales a constraint's information (iteratively reweighted least squares); default 1.
  /// chi2() and constraintChi2() stay unweighted; OptimizationResult's chi2 values are weighted.
  void setWeight(int constraint, double weight) {
    auto& w = weight_[static_cast<std::size_t>(constraint)];
    if (w != weight) covariance_valid_ = false;
    w = weight;
  }
  bool isActive(int constraint) const { return active_[static_cast<std::size_t>(constraint)]; }
  void setFixed(int node, bool fixed);
  bool isFixed(int node) const { return fixed_[static_cast<std::size_t>(node)]; }

  int numNodes() const { return static_cast<int>(poses_.size()); }
  int numConstraints() const { return static_cast<int>(constraints_.size()); }
  int from(int constraint) const { return constraints_[static_cast<std::size_t>(constraint)].from; }
  int to(int constraint) const { return constraints_[static_cast<std::size_t>(constraint)].to; }
  const Pose2& measurement(int constraint) const {
    return constraints_[static_cast<std::size_t>(constraint)].measurement;
  }
  const Eigen::Matrix3d& information(int constraint) const {
    return constraints_[static_cast<std::size_t>(constraint)].information;
  }

  const std::vector<Pose2>& poses() const { return poses_; }
  void setPoses(const std::vector<Pose2>& poses);

  /// chi2 of the active constraints at the current poses.
  double chi2() const;
  /// Same, with each constraint's weight applied.
  double weightedChi2() const;
  /// e^T Omega e of one constraint at the current poses, whether active or not.
  double constraintChi2(int constraint) const;

  /// Iterates from the current poses and leaves the result in poses() (the last poses with a
  /// finite chi2: a step that makes it NaN is not taken).
  OptimizationResult optimize();
  /// The same, from the request's start with its method and limits.
  OptimizationResult optimize(const OptimizationRequest& request);
  /// optimize() checks `*flag` before each step and stops with kCancelled when it is set (from
  /// another thread); nullptr (default) disables. The flag must outlive its use.
  void setCancelFlag(const std::atomic<bool>* flag) { cancel_ = flag; }
  const std::atomic<bool>* cancelFlag() const { return cancel_; }

  /// True when the last factorization was an undamped Gauss-Newton one of the current active
  /// set, so that covariance() describes the current estimate (to first order). Nodes added since
  /// keep it available when each hangs from an earlier node by one active constraint added since,
  /// and no other constraint added since is active (a growing graph's odometry): such a tree
  /// leaves the factored nodes' marginals as they are.
  bool covarianceAvailable() const {
    std::vector<int> parent;
    return covariance_valid_ && nodesAddedAsTree(parent);
  }
  /// One undamped factorization of H at the current poses, without a step, so that covariance()
  /// describes them (to first order) when the last optimization ended damped or elsewhere
  /// (Levenberg-Marquardt at its iteration limit). False when H cannot be factored (or every
  /// node is fixed).
  bool factorAtCurrentPoses();
  /// Joint marginal covariance (3m x 3m, node order as given) of `nodes` from the last
  /// factorization; fixed nodes have zero covariance. A node added since gets its parent's,
  /// propagated through the constraint it hangs from, linearized at the current poses (exact to
  /// first order, as the tree adds no information about the rest). Zero unless
  /// covarianceAvailable(); std::out_of_range for a node that does not exist.
  Eigen::MatrixXd covariance(const std::vector<int>& nodes) const;
  /// A 3x3 block of a linear function J of the poses: J's rows 3 row .. 3 row + 2, its columns
  /// of `node`.
  struct JacobianBlock {
    int row;
    int node;
    Eigen::Matrix3d value;
  };
  /// J Sigma J' (3 rows x 3 rows): the covariance of J dx for J given by its blocks (repeated
  /// blocks add up), as J covariance(J's nodes) J' gives it. With every node of J factored it is
  /// read from the factor directly (SparseSolver::inverseProjection): one forward solve per row
  /// of J, not per row of the nodes' joint covariance (a loop link's relative pose: 3 rows for
  /// two nodes' 6). Zero unless covarianceAvailable(); std::out_of_range for a node that does not
  /// exist or a block outside J's rows.
  Eigen::MatrixXd projectedCovariance(const std::vector<JacobianBlock>& J, int rows) const;

  /// The information matrix H = sum_k J_k^T (w_k Omega_k) J_k of the active constraints (and the
  /// dense factors) at the current poses, 3 rows and columns per node in node order (fixed nodes
  /// included, anchors' weak priors left out): what marginalizing nodes out of the graph starts
  /// from. Built directly from the constraints, independent of the solver's ordering and factor.
  Eigen::SparseMatrix<double> informationMatrix() const;

  /// Symbolic analyses done so far (one per sparsity pattern).
  int symbolicAnalyses() const { return solver_.analysisCount(); }
  /// The numeric factorizations of H done so far (optimizations and factorAtCurrentPoses).
  const FactorizationWork& factorizationWork() const { return solver_.work(); }

 private:
  struct Constraint {
    int from;
    int to;
    Pose2 measurement;
    Eigen::Matrix3d information;
  };
  // Where one constraint's blocks live in H; a fixed end has variable -1.
  struct ConstraintSlots {
    int from_var = -1;
    int to_var = -1;
    BlockHessian::OffDiagonalSlots off_diagonal{};
  };

  // A dense factor, the optimizer's node of each factor node, and where its blocks live in H:
  // the variable of each node (-1 fixed) and the slots of each pair (a < b in factor order, row
  // by row) whose two nodes are variables.
  struct Dense {
    DenseFactor factor;
    std::vector<int> nodes;
    std::vector<int> vars;
    std::vector<BlockHessian::OffDiagonalSlots> pair_slots;
  };

  void prepareStructure();
  // The dense factors' part of assemble().
  double assembleDense(bool with_hessian);
  int reservedSlots() const { return params_.factor_updates ? params_.reserved_slots : 0; }
  void rebuildPattern();
  void chooseAnchors();
  // Gradient (and H unless !with_hessian) at the current poses; returns the weighted chi2.
  double assemble(bool with_hessian = true);
  bool updateFactor(OptimizationResult& result);
  void rememberFactoredState();
  void gaussNewton(OptimizationResult& result, double& chi2_now, bool start_with_factor,
                   std::chrono::steady_clock::time_point& clock);
  void levenbergMarquardt(OptimizationResult& result, double& chi2_now,
                          std::chrono::steady_clock::time_point& clock);
  void applyStep(const Eigen::VectorXd& step);
  // For covarianceAvailable(): the constraint each node added since the factorization hangs
  // from (indexed from the first such node); false if they do not form such a tree.
  bool nodesAddedAsTree(std::vector<int>& parent) const;
  // Marginal covariance of factored nodes, read from the factor.
  Eigen::MatrixXd factorCovariance(const std::vector<int>& nodes) const;

  bool cancelled() const { return cancel_ != nullptr && cancel_->load(); }

  OptimizerParams params_;
  const std::atomic<bool>* cancel_ = nullptr;
  std::vector<Pose2> poses_;
  std::vector<Constraint> constraints_;
  std::vector<char> active_;
  std::vector<double> weight_;
  std::vector<char> fixed_;
  std::vector<Dense> dense_;

  // Structure, valid until the fixed set changes or an active constraint is not in the pattern.
  bool variables_valid_ = false;
  std::vector<int> variable_of_node_;  // -1 for fixed nodes
  int num_variables_ = 0;              // the nodes' variables, then the reserved slots
  int used_variables_ = 0;  // variables held by nodes: [used_variables_, num_variables_) are free
  bool pattern_valid_ = false;
  std::vector<char> in_pattern_;
  int pattern_size_ = 0;
  std::vector<ConstraintSlots> slots_;
  BlockHessian hessian_;
  SparseSolver solver_;

  bool covariance_valid_ = false;
  // The active set, weights and anchors the factorization in solver_ stands for (GN, undamped).
  bool factor_valid_ = false;
  int updates_since_factorization_ = 0;
  std::vector<char> factored_active_;
  std::vector<double> factored_weight_;
  std::vector<int> factored_anchors_;
  int factored_nodes_ = 0;        // nodes and constraints when the factor was last made or
  int factored_constraints_ = 0;  // updated
  std::vector<int> anchors_;      // nodes held by a weak prior, with their anchor poses
  std::vector<Pose2> anchor_poses_;
  Eigen::VectorXd gradient_;
};

/// An optimizer holding `graph`: node k is the k-th smallest id, constraint k is edge k.
Optimizer makeOptimizer(const PoseGraph& graph, const OptimizerParams& params = {});
/// Writes the optimizer's poses back into the graph (same node order as makeOptimizer).
void copyPosesToGraph(const Optimizer& optimizer, PoseGraph& graph);

}  // namespace rrr_graphslam::core
