#pragma once
// Local SLAM (Cartographer's LocalTrajectoryBuilder2D): every scan is matched against the active
// submap, starting from the odometry prediction (correlative search, then least squares or MRPT's
// ICP; the search also runs around a constant-velocity prediction when the odometry disagrees
// with it); scans that moved far enough since the last inserted one (the motion filter) become
// nodes and are inserted into both active submaps. A scan that cannot be placed (non-finite or
// absurd odometry, an odometry jump, a laser mounted far from the robot) is refused (ScanRefused),
// so a wheel slip or a tf glitch never reaches the grids.

#include <memory>
#include <optional>
#include <stdexcept>

#include "rrr_graphslam/core/keyframe_selector.h"
#include "rrr_graphslam/frontend/icp_refinement.h"
#include "rrr_graphslam/frontend/plausible_pose.h"
#include "rrr_graphslam/frontend/range_scan.h"
#include "rrr_graphslam/frontend/scan_matcher.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

struct LocalSlamParams {
  RangeScanParams scan;
  SubmapParams submap;
  /// Real-time correlative search before the refinement; a linear window of 0 switches it off.
  CorrelativeParams correlative;
  /// What refines the correlative pose: Gauss-Newton on the interpolated probabilities (default)
  /// or MRPT's ICP against the submap's occupied cells.
  enum class Refinement { kLeastSquares, kIcp };
  Refinement refinement = Refinement::kLeastSquares;
  LeastSquaresParams least_squares;
  IcpRefinementParams icp;
  /// Motion filter: a scan becomes a node after this much travel or rotation.
  core::KeyframeParams motion_filter{0.1, 2.0 * M_PI / 180};
  /// Scans with fewer matching points are not matched (the prediction is kept).
  int min_points = 20;
  /// Odometry wrong by more than the correlative window (a wheel slip; a base that reports
  /// forward motion while it backs up, as in the FR079 log) would hold each scan at the window's
  /// edge. With this on, when the constant-velocity prediction (the last scan's step, scaled
  /// to this scan's interval) lies more than half a window from the odometry's, the
  /// window is searched around it too, and its match is taken if it scores at least 10% better.
  bool velocity_prediction = true;
  /// A scan whose odometry moved more than this (m) since the previous scan is refused, and the
  /// odometry is re-anchored at it: the scans after it are tracked from there as if the robot had
  /// stood still across the jump (a wheel slip, an odometry reset). Default 5 m.
  double max_odometry_jump_m = 5.0;
  /// A session's first submap is young (SubmapParams::young_submap_scans) only when the session
  /// starts while the robot drives: its odometry moved faster than this (m/s) over the session's
  /// first interval between scans of 0-1 s (no such interval: as from rest). Starts from rest
  /// (every log's own start) gain nothing from a young submap and lose a little; sessions that
  /// start at speed (a node restarted while the robot drives, a log split anywhere) are held back
  /// without it (doc/benchmarks.md#sessions-that-start-while-the-robot-drives). Default 0.05 m/s;
  /// 0: every session's first submap is young.
  double young_submap_start_speed = 0.05;
};

/// Why LocalSlam (and LaserSlam) refused a scan; the message names the value and the limit.
class ScanRefused : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct LocalSlamResult {
  core::Pose2 local_pose;  ///< the scan's robot pose in the local SLAM frame
  PointCloud points;       ///< matching points, robot frame
  bool matched = false;    ///< false: the odometry prediction was kept
  /// The match came from the window around the constant-velocity prediction, which scored
  /// better than the odometry's (LocalSlamParams::velocity_prediction).
  bool velocity_predicted = false;
  /// Set when the scan became node `node` and was inserted (as `observation`).
  std::optional<int> node;
  std::optional<mrpt::obs::CObservation2DRangeScan> observation;
  /// A submap this insertion finished.
  std::shared_ptr<Submap> finished_submap;
};

class LocalSlam {
 public:
  /// Nodes are numbered from `first_node` and submaps from `first_submap` (a session that
  /// continues a loaded map goes on from the map's numbers).
  explicit LocalSlam(const LocalSlamParams& params, int first_node = 0, int first_submap = 0);

  /// A scan with the robot's odometry pose at its time. The local frame starts at the first
  /// scan's odometry pose. Throws ScanRefused, leaving the state as it was (but for the odometry
  /// re-anchored after a jump), for odometry that is not finite or beyond 1e6 m, an odometry step
  /// above max_odometry_jump_m, or a laser more than 100 m from the robot.
  LocalSlamResult addScan(const RangeScan& scan, const core::Pose2& odom_pose);

  const ActiveSubmaps& submaps() const { return submaps_; }
  int numNodes() const { return next_node_; }
  const LocalSlamParams& params() const { return params_; }

  /// Where local SLAM stands, to be continued elsewhere (online trimming renumbers what is
  /// before it): a copy, taken on the thread that adds scans, that shares nothing with it.
  struct Checkpoint;
  Checkpoint checkpoint() const;
  /// The local SLAM `checkpoint` was taken from, with its nodes numbered k - node_shift and its
  /// submaps i - submap_shift; `scan_of(k)` is the scan node k (new numbering) inserted. The next
  /// scan is matched, filtered and inserted exactly as it would have been there.
  static LocalSlam resume(const Checkpoint& checkpoint, int node_shift, int submap_shift,
                          const ActiveSubmaps::ScanOf& scan_of);

 private:
  void checkPlausible(const RangeScan& scan, const core::Pose2& odom_pose);
  /// Whether the session started at speed (young_submap_start_speed), judged on the first
  /// interval since the previous scan that can be: the first submap is young from then on if so.
  void judgeStart(double stamp, const core::Pose2& odom_pose);
  /// The last step (matched, or the odometry's when that scan could not be matched) repeated
  /// over this scan's interval, when both intervals are known and within 2x of each other.
  std::optional<core::Pose2> velocityPrediction(double stamp) const;
  struct WindowMatch {
    core::Pose2 pose;    ///< the correlative match
    core::Pose2 center;  ///< the prediction whose window it came from
    bool velocity_predicted = false;
  };
  /// The correlative match, searched around the odometry's prediction and, when the velocity
  /// prediction disagrees with it, around that too.
  WindowMatch searchWindows(const MatchGrid& grid, const PointCloud& points, double stamp,
                            const core::Pose2& prediction) const;

  LocalSlamParams params_;
  ActiveSubmaps submaps_;
  core::KeyframeSelector motion_filter_;
  bool started_ = false;
  core::Pose2 last_odom_ = core::Pose2::Zero();
  core::Pose2 last_local_ = core::Pose2::Zero();
  /// The last scan's local step and the seconds since the scan before it (the velocity).
  struct Motion {
    core::Pose2 step;
    double seconds;
  };
  std::optional<Motion> last_motion_;
  double last_stamp_ = 0.0;
  int next_node_ = 0;
  bool start_judged_ = false;  // judgeStart decided
};

struct LocalSlam::Checkpoint {
  LocalSlam state;  ///< without active submaps: they are rebuilt from `active`
  std::vector<ActiveSubmaps::Contents> active;
};

}  // namespace rrr_graphslam::frontend
