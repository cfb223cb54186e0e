#pragma once
// The graph lifelong trimming works on (map_trimming.h, steps 3-4): a map's trusted constraints
// (odometry, accepted loops, marginal edges) and dense factors over its node indices, at poses
// that start as the map's. Each trim marginalizes one group of nodes at once (Schur complement
// over their Markov blanket, core/marginalization.h) and puts its replacement in their place: the
// Chow-Liu tree's marginal constraints, the dense factors of the exact marginal, or nothing.
// Nodes keep their indices; removed ones are only marked.

#include <cstddef>
#include <vector>

#include "rrr_graphslam/core/dense_factor.h"
#include "rrr_graphslam/core/linearized_constraints.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/map_snapshot.h"

namespace rrr_graphslam::core {
class Optimizer;
struct Marginal;
}  // namespace rrr_graphslam::core

namespace rrr_graphslam::frontend {

struct TrimParams;
struct TrimRecord;

class TrimGraph {
 public:
  /// A trusted constraint: an edge of the map (`origin`, its index), or a marginal constraint a
  /// trim made (origin -1, `submap` the trimmed submap whose nodes it replaces).
  struct Constraint {
    core::PoseConstraint constraint;
    int origin = -1;
    int submap = -1;
  };

  /// The map's trusted graph at its map poses.
  explicit TrimGraph(const MapSnapshot& map);

  std::size_t size() const { return poses_.size(); }
  bool alive(std::size_t node) const { return alive_[node] != 0; }
  const std::vector<core::Pose2>& poses() const { return poses_; }
  const std::vector<Constraint>& constraints() const { return constraints_; }
  const std::vector<core::DenseFactor>& denseFactors() const { return dense_; }

  /// Moves the nodes still alive to the graph's minimum.
  void optimize();

  /// Marginalizes `group` (the nodes trimmed submaps own; `record.submap` the oldest of them) at
  /// the current poses and replaces the constraints and dense factors that touch it by
  /// `params.sparsification`'s. A part of the group that no constraint joins to a node outside it
  /// (a session nothing else saw) carries no information about the rest and just leaves. Fills
  /// `record`'s counts, and its KL figures with `params.report_kl` (the whole graph's covariance
  /// over the blanket: one factorization).
  void marginalize(const std::vector<core::NodeId>& group, const TrimParams& params,
                   TrimRecord& record);

 private:
  /// The graph over the nodes still alive, at their poses, in an optimizer (not yet optimized or
  /// factored); `index_of` the optimizer's index of each node (-1 for removed ones).
  core::Optimizer optimizer(std::vector<int>& index_of) const;
  /// TrimRecord's KL figures for `marginal`, replaced by the tree, by deletion and by what
  /// params.sparsification made (`replacement`: the dense factors, for kDense).
  void measureKl(const core::Marginal& marginal, const std::vector<core::DenseFactor>& replacement,
                 const TrimParams& params, TrimRecord& record) const;

  std::vector<Constraint> constraints_;
  std::vector<core::DenseFactor> dense_;
  std::vector<core::Pose2> poses_;
  std::vector<char> alive_;
};

}  // namespace rrr_graphslam::frontend
