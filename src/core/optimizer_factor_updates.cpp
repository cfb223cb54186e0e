// Optimizer, factor updates: the last undamped factorization brought up to date by CHOLMOD rank
// updates for the constraints switched on or off and the nodes added on reserved slots since.

#include <Eigen/Cholesky>
#include <Eigen/SparseCore>

#include "rrr_graphslam/core/optimizer.h"

namespace rrr_graphslam::core {

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

}  // namespace rrr_graphslam::core
