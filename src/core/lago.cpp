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

// A relative pose LAGO uses: an active constraint, or one residual block of a dense factor (its
// node's pose in the root's frame at the factor's minimum, weighted by its own diagonal block of
// the information: the correlations between blocks are left out, as LAGO leaves out the
// x-y-theta correlations of an edge).
struct Relation {
  int from;
  int to;
  Pose2 measurement;
  Eigen::Matrix3d information;
};

std::vector<Relation> relations(const Optimizer& optimizer) {
  std::vector<Relation> out;
  for (int c = 0; c < optimizer.numConstraints(); ++c) {
    if (!optimizer.isActive(c)) continue;
    out.push_back(
        {optimizer.from(c), optimizer.to(c), optimizer.measurement(c), optimizer.information(c)});
  }
  for (int f = 0; f < optimizer.numDenseFactors(); ++f) {
    const DenseFactor& factor = optimizer.denseFactor(f);
    const std::vector<int>& nodes = optimizer.denseFactorNodes(f);
    for (std::size_t a = 0; a + 1 < nodes.size(); ++a) {
      const auto at = static_cast<Eigen::Index>(3 * a);
      // edgeError(x_root, x, y) = mean at x = root * y * v2t(mean): its pose in the root's frame.
      const Pose2 minimum = compose(factor.measurements[a], Pose2(factor.mean.segment<3>(at)));
      out.push_back({nodes.front(), nodes[a + 1], minimum, factor.information.block<3, 3>(at, at)});
    }
  }
  return out;
}

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

  const std::vector<Relation> measured = relations(optimizer);
  LinearProblem angles(n);
  for (const Relation& c : measured) {
    const int i = c.from, j = c.to;
    const double z = c.measurement.z();
    const double turns = std::round(
        (unwrapped[static_cast<std::size_t>(j)] - unwrapped[static_cast<std::size_t>(i)] - z) /
        (2.0 * M_PI));
    const Eigen::Matrix3d& info = c.information;
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
  for (const Relation& c : measured) {
    const int i = c.from, j = c.to;
    const Eigen::Vector2d d = rotation(theta(i)) * c.measurement.head<2>();
    const Eigen::Matrix2d cov = c.information.inverse().topLeftCorner<2, 2>();
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
  int active = 0;  // relative poses: active constraints and the dense factors' residual blocks
  for (int k = 0; k < optimizer.numConstraints(); ++k) active += optimizer.isActive(k) ? 1 : 0;
  for (int f = 0; f < optimizer.numDenseFactors(); ++f) {
    active += optimizer.denseFactor(f).dimension() / 3;
  }
  return active > 0 && optimizer.chi2() > chi2_per_constraint * active;
}

}  // namespace rrr_graphslam::core
