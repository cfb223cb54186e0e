#pragma once
// A submap (Cartographer's term): an occupancy grid built from a fixed number of consecutive
// scans at their local-SLAM poses, held in MRPT's COccupancyGridMap2D (log-odds cells, hit/miss
// updates along each ray). Its frame is the local SLAM frame; its anchor is the first node inserted
// (a loop candidate is a constraint between the anchor and the node matched against the submap).
// Once finished it is frozen into a MatchGrid and the branch-and-bound max-grids, and the MRPT grid
// is released.

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "rrr_graphslam/frontend/branch_and_bound.h"
#include "rrr_graphslam/frontend/match_grid.h"

namespace rrr_graphslam::frontend {

struct SubmapParams {
  /// Insertions until finished; a new submap starts at half. Default 120: local SLAM drifts
  /// within a submap (FR079: up to 6 degrees over 240 nodes, 5 over 120), which bends its grid and
  /// the loops matched against it, and a place revisited within a large submap's span is never
  /// searched (issue 24; FR079 ATE 0.20 -> 0.09 m, ACES relation error unchanged).
  int scans_per_submap = 120;
  double resolution_m = 0.05;
  /// Rays are inserted up to this range (misses clear space up to it); keep it at the scan's
  /// max_range_m.
  float max_insertion_range_m = 30.0F;
  float hit_probability = 0.55F;   ///< MRPT's maxOccupancyUpdateCertainty
  float miss_probability = 0.49F;  ///< MRPT's maxFreenessUpdateCertainty is 1 - this
  /// What never-observed cells score when a finished submap is matched (loop search, the map
  /// agreement check): a scan placed in space no scan saw is suspect. Default 0.1.
  float unknown_value = 0.1F;
  /// What they score while the submap is active, matched by local SLAM. A young submap (a
  /// session's first, of a scan or a few) has seen little, and at 0.1 every point beyond what it
  /// saw pulls the scan back inside: along a corridor the robot is held back and a session's
  /// first metres come out short. At 0.5, the occupancy prior, such a point is no evidence either
  /// way, but in every submap: FR clinic's map then drifts apart (doc/benchmarks.md#sessions).
  /// Default 0.1, as finished submaps.
  double active_unknown_value = 0.1;
  /// A session's first submap's instead: while it holds fewer than young_submap_scans scans (and
  /// fewer than half of scans_per_submap, when the next submap starts), its never-observed cells
  /// score young_unknown_value (0.5, the occupancy prior: no evidence either way), so a session's
  /// first scans are not held back where its first submap saw nothing yet; from then on
  /// active_unknown_value. Later submaps never (ActiveSubmaps gives the rule to the first submap
  /// it starts only), and only once ActiveSubmaps::startYouth said so (LocalSlam does when the
  /// session starts at speed: young_submap_start_speed). Default 20; 0: off.
  int young_submap_scans = 20;
  double young_unknown_value = 0.5;
  int branch_and_bound_depth = 7;  ///< levels of max-grids built when the submap is finished
  /// Branch and bound searches a grid this many times coarser than resolution_m (max-pooled, so
  /// its bounds stay bounds); the least-squares refinement of a match and a final min_score
  /// check read the full-resolution grid. Default 2 (10 cm): half the angles and a quarter of the
  /// translations of a 5 cm search (FR079 16 -> 7 ms per pair, ACES 0.0350 -> 0.0348 m).
  int search_grid_factor = 2;
};

/// MRPT insertion options of a grid built like a submap (hit/miss updates, insertion range); the
/// rendered map uses them too.
void configureInsertion(mrpt::maps::COccupancyGridMap2D& grid, const SubmapParams& params);

class Submap {
 public:
  Submap(int index, int anchor_node, const core::Pose2& anchor_local_pose,
         const SubmapParams& params);

  int index() const { return index_; }
  int anchorNode() const { return anchor_node_; }
  int lastNode() const { return last_node_; }
  /// The anchor's local-SLAM pose (the submap frame is the local frame).
  const core::Pose2& anchorPose() const { return anchor_pose_; }
  int numScans() const { return num_scans_; }
  bool finished() const { return matcher_ != nullptr; }

  /// Inserts a scan taken at `local_pose` by node `node`. Throws std::logic_error once finished.
  void insert(const mrpt::obs::CObservation2DRangeScan& scan, const core::Pose2& local_pose,
              int node);
  /// Freezes the grid: builds the match grid and the branch-and-bound max-grids.
  void finish();
  /// Young while it holds fewer than `scans` scans from now on (SubmapParams::young_submap_scans).
  void setYoungScans(int scans);

  /// A node inserted into the submap, with its local-SLAM pose (the submap frame).
  struct Member {
    int node;
    core::Pose2 local_pose;
  };
  /// Every node inserted, in insertion order (the anchor first).
  const std::vector<Member>& members() const { return members_; }

  /// The grid as matching reads it (rebuilt lazily after insertions while active): never-observed
  /// cells score young_unknown_value while the submap is young (SubmapParams::young_submap_scans),
  /// then active_unknown_value while it is active, unknown_value once finished.
  const MatchGrid& matchGrid() const;
  /// The MRPT grid while the submap is active (nullptr once finished: it is released).
  const mrpt::maps::COccupancyGridMap2D* grid() const { return grid_.get(); }
  /// Branch-and-bound matcher; only for finished submaps (nullptr before).
  const FastCorrelativeScanMatcher* matcher() const { return matcher_.get(); }

 private:
  int index_;
  int anchor_node_;
  int last_node_;
  core::Pose2 anchor_pose_;
  SubmapParams params_;
  int num_scans_ = 0;
  std::vector<Member> members_;
  std::unique_ptr<mrpt::maps::COccupancyGridMap2D> grid_;
  mutable MatchGrid match_grid_;
  mutable bool match_grid_dirty_ = true;
  std::unique_ptr<FastCorrelativeScanMatcher> matcher_;
};

/// The two submaps local SLAM inserts into (Cartographer's ActiveSubmaps2D): every scan goes into
/// both; the older one is finished after scans_per_submap insertions, and a new one starts when
/// the newer one is half full, so consecutive submaps overlap by half.
class ActiveSubmaps {
 public:
  /// Submaps are numbered from `first_index`; that one, the session's first, is the only one
  /// young_submap_scans applies to (after startYouth).
  explicit ActiveSubmaps(const SubmapParams& params, int first_index = 0);

  /// Inserts; returns the submap finished by this insertion, if any.
  std::shared_ptr<Submap> insert(const mrpt::obs::CObservation2DRangeScan& scan,
                                 const core::Pose2& local_pose, int node);
  /// The submap to match new scans against (the older, fuller one); nullptr before any insertion.
  std::shared_ptr<const Submap> matchingSubmap() const {
    return active_.empty() ? nullptr : active_.front();
  }
  const std::vector<std::shared_ptr<Submap>>& active() const { return active_; }
  /// Index the next submap will take (the number started so far, plus the first index).
  int numSubmaps() const { return next_index_; }
  /// The session's first submap is young (SubmapParams::young_submap_scans), from now on and if
  /// rebuilt; before this call no submap is.
  void startYouth();

  /// What an active submap is made of: the insertions that rebuild it exactly.
  struct Contents {
    int index;
    core::Pose2 anchor_pose;
    std::vector<Submap::Member> members;
  };
  /// The active submaps' contents, oldest first (a copy: they go on changing here).
  std::vector<Contents> contents() const;
  /// The node (numbered as the insertions were) whose scan is asked for.
  using ScanOf = std::function<const mrpt::obs::CObservation2DRangeScan&(int node)>;
  /// Replaces the active submaps by `contents` rebuilt (the same insertions in the same order
  /// give the same grids), with node k numbered k - node_shift and submap i numbered
  /// i - submap_shift, as are the submaps started from now on; `scan_of(k)` is the scan node k
  /// (new numbering) inserted.
  void rebuild(const std::vector<Contents>& contents, int node_shift, int submap_shift,
               const ScanOf& scan_of);

 private:
  // The parameters of submap `index`: young_submap_scans for the session's first only.
  SubmapParams paramsOf(int index) const;

  SubmapParams params_;
  std::vector<std::shared_ptr<Submap>> active_;
  int first_index_ = 0;
  int next_index_ = 0;
  bool start_next_ = true;
  bool young_ = false;  // the first submap is young (startYouth was called)
};

}  // namespace rrr_graphslam::frontend
