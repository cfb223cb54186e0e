#pragma once
// 2D laser SLAM: local SLAM builds nodes and submaps, the loop search proposes candidates between
// nodes and finished submaps, and RRR (rrr::OnlineRrr, the same object the nodelet uses) decides
// which of them the map keeps. rrr_slam_offline and the nodelet's slam mode both drive this class.
//
// Graph: node k is the k-th scan the motion filter let through; odometry edges join consecutive
// nodes with the local-SLAM relative pose; loop candidates join a submap's anchor node to the
// matched node. Every scan (node or not) keeps its pose relative to the newest node at its time,
// so the whole trajectory follows the optimized nodes.

#include <memory>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "rrr_graphslam/frontend/laser_slam_params.h"
#include "rrr_graphslam/frontend/local_slam.h"
#include "rrr_graphslam/frontend/loop_search.h"
#include "rrr_graphslam/frontend/map_render.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::frontend {

/// Counters for progress lines and benchmarks.
struct LaserSlamStats {
  int scans = 0;
  int matched_scans = 0;
  int refused_scans = 0;  ///< ScanRefused (not counted in scans)
  int nodes = 0;
  int submaps = 0;
  int finished_submaps = 0;
  long long loop_searches = 0;            ///< node-submap pairs searched by branch and bound
  double loop_search_seconds = 0.0;       ///< wall time (the searches of a node run in parallel)
  double loop_search_pair_seconds = 0.0;  ///< sum over the pairs of each one's own time
  double local_slam_seconds = 0.0;
  double rrr_seconds = 0.0;
  int candidates = 0;
};

class LaserSlam {
 public:
  explicit LaserSlam(const LaserSlamParams& params = {});

  /// One scan with the robot's odometry pose at its time. Returns the node it became, if any.
  /// Throws ScanRefused (local_slam.h) for a scan it cannot place; the run goes on.
  std::optional<int> addScan(const RangeScan& scan, const core::Pose2& odom_pose);
  /// End of the run: RRR decides every cluster from scratch.
  void finish();

  const rrr::OnlineRrr& rrr() const { return *rrr_; }
  rrr::OnlineRrr& rrr() { return *rrr_; }
  const LaserSlamStats& stats() const { return stats_; }
  const LaserSlamParams& params() const { return params_; }

  /// Map pose of every scan so far (log order), following the current node estimates.
  std::vector<core::Pose2> scanMapPoses() const;
  /// Timestamps of every scan so far.
  const std::vector<double>& scanTimestamps() const { return scan_timestamps_; }
  /// What the occupancy map is made of now (the scans shared, not copied).
  MapInputs mapInputs() const;
  /// The occupancy map: every node's scan inserted at its map pose.
  mrpt::maps::COccupancyGridMap2D renderMap(double resolution_m) const {
    return renderOccupancyMap(mapInputs(), resolution_m);
  }

 private:
  void searchLoops(int node, const PointCloud& points);

  LaserSlamParams params_;
  LocalSlam local_;
  std::unique_ptr<rrr::OnlineRrr> rrr_;
  Eigen::Matrix3d odometry_information_;
  std::vector<std::shared_ptr<const Submap>> finished_;
  std::vector<core::Pose2> node_local_poses_;
  std::vector<std::shared_ptr<const mrpt::obs::CObservation2DRangeScan>> node_scans_;
  // Per scan: the newest node at its time and the scan's pose relative to it.
  std::vector<int> scan_node_;
  std::vector<core::Pose2> scan_offset_;
  std::vector<double> scan_timestamps_;
  struct SubmapSearchState {
    int last_searched = -1000000000;
    int last_matched = -1000000000;
  };
  std::vector<SubmapSearchState> search_state_;  // by submap index
  LaserSlamStats stats_;
};

}  // namespace rrr_graphslam::frontend
