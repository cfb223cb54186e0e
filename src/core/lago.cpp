#include "rrr_graphslam/core/lago.h"

#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <cmath>

#include "rrr_graphslam/core/sparse_solver.h"

namespace rrr_graphslam::core {
namespace {

// Solves the normal equations sum_k w_k (x_to - x_from - d_k)^2 per coordinate block, with a
// tiny prior pulling every unknown to `prior` (holds the gauge and unreached nodes) and a
// strong one holding each gauge node.
struct LinearProblem {
  explicit LinearProblem(int n) : n_(n), rhs_(Eigen::VectorXd::Zero(n)) {}

  void addDifference(int from, int to, double weight, double difference) {
    add(from, from, weight);
    add(to, to, weight);
    add(std::min(from, to), std::max(from, to), -weight);
    rhs_(from) -= weight * difference;
    rhs_(to) += weight * difference;
  }
  void addPrior(int i, double weight, double value) {
    add(i, i, weight);
    rhs_(i) += weight * value;
  }
  Eigen::VectorXd solve() {
    SparseSolver::Matrix upper(n_, n_);
    upper.setFromTriplets(triplets_.begin(), triplets_.end());
    upper.makeCompressed();
    SparseSolver solver;
    solver.analyze(upper);
    if (!solver.factorize(upper)) return Eigen::VectorXd();
    return solver.solve(rhs_);
  }

 private:
  void add(int r, int c, double v) { triplets_.emplace_back(r, c, v); }
  int n_;
  Eigen::VectorXd rhs_;
  std::vector<Eigen::Triplet<double>> triplets_;
};

constexpr double kWeakPrior = 1e-9;
constexpr double kGaugePrior = 1e9;

}  // namespace

std::vector<Pose2> lagoInitialization(const Optimizer& optimizer) {
  const int n = optimizer.numNodes();
  std::vector<Pose2> poses = optimizer.poses();
  if (n < 2) return poses;
  // The optimizer's gauge: its fixed nodes, or node 0 when none is.
  std::vector<int> gauge;
  for (int i = 0; i < n; ++i) {
    if (optimizer.isFixed(i)) gauge.push_back(i);
  }
  if (gauge.empty()) gauge.push_back(0);

  // Current orientations unwrapped along node order: the reference each measured angle is
  // unwrapped against.
  std::vector<double> unwrapped(static_cast<std::size_t>(n));
  unwrapped[0] = poses[0].z();
  for (int i = 1; i < n; ++i) {
    unwrapped[static_cast<std::size_t>(i)] =
        unwrapped[static_cast<std::size_t>(i - 1)] +
        normalizeAngle(poses[static_cast<std::size_t>(i)].z() -
                       poses[static_cast<std::size_t>(i - 1)].z());
  }

  LinearProblem angles(n);
  for (int c = 0; c < optimizer.numConstraints(); ++c) {
    if (!optimizer.isActive(c)) continue;
    const int i = optimizer.from(c), j = optimizer.to(c);
    const double z = optimizer.measurement(c).z();
    const double turns = std::round(
        (unwrapped[static_cast<std::size_t>(j)] - unwrapped[static_cast<std::size_t>(i)] - z) /
        (2.0 * M_PI));
    const Eigen::Matrix3d& info = optimizer.information(c);
    // Marginal angular information: 1 / (Sigma)_thetatheta.
    const double weight = 1.0 / info.inverse()(2, 2);
    angles.addDifference(i, j, weight, z + 2.0 * M_PI * turns);
  }
  for (int i = 0; i < n; ++i)
    angles.addPrior(i, kWeakPrior, unwrapped[static_cast<std::size_t>(i)]);
  for (int i : gauge) angles.addPrior(i, kGaugePrior, unwrapped[static_cast<std::size_t>(i)]);
  const Eigen::VectorXd theta = angles.solve();
  if (theta.size() != n) return poses;

  // Positions given the orientations: t_j - t_i = R(theta_i) z_t. x and y decouple when the
  // translational information is taken isotropic (its mean eigenvalue); exact enough to start.
  LinearProblem xs(n), ys(n);
  for (int c = 0; c < optimizer.numConstraints(); ++c) {
    if (!optimizer.isActive(c)) continue;
    const int i = optimizer.from(c), j = optimizer.to(c);
    const Eigen::Vector2d d = rotation(theta(i)) * optimizer.measurement(c).head<2>();
    const Eigen::Matrix2d cov = optimizer.information(c).inverse().topLeftCorner<2, 2>();
    const double weight = 2.0 / cov.trace();
    xs.addDifference(i, j, weight, d.x());
    ys.addDifference(i, j, weight, d.y());
  }
  for (int i = 0; i < n; ++i) {
    xs.addPrior(i, kWeakPrior, poses[static_cast<std::size_t>(i)].x());
    ys.addPrior(i, kWeakPrior, poses[static_cast<std::size_t>(i)].y());
  }
  for (int i : gauge) {
    xs.addPrior(i, kGaugePrior, poses[static_cast<std::size_t>(i)].x());
    ys.addPrior(i, kGaugePrior, poses[static_cast<std::size_t>(i)].y());
  }
  const Eigen::VectorXd x = xs.solve();
  const Eigen::VectorXd y = ys.solve();
  if (x.size() != n || y.size() != n) return poses;
  for (int i = 0; i < n; ++i) {
    // A fixed node keeps its pose exactly (the strong prior holds it to ~1e-9 of it).
    if (optimizer.isFixed(i)) continue;
    poses[static_cast<std::size_t>(i)] = Pose2(x(i), y(i), normalizeAngle(theta(i)));
  }
  return poses;
}

bool farFromMinimum(const Optimizer& optimizer, double chi2_per_constraint) {
  int active = 0;
  for (int k = 0; k < optimizer.numConstraints(); ++k) active += optimizer.isActive(k) ? 1 : 0;
  return active > 0 && optimizer.chi2() > chi2_per_constraint * active;
}

}  // namespace rrr_graphslam::core
