#pragma once
// Online trimming: while a session maps, the submaps that newer ones cover are trimmed
// (map_trimming.h), every `every_n_nodes` nodes of the session once LaserSlam::trimsWhileMapping
// (tied to the map; in a first session, with keep_current_session off): the earlier sessions'
// submaps, and without keep_current_session the session's own older ones.
// LaserSlam::checkpoint() is taken after the scan that made the due node; the trim and the
// rebuild of the map (LaserSlam::trimmed) run on a thread of their own while the running map
// goes on; the scans it took meanwhile are then given to the trimmed one, which replaces it.
// The nodelet uses it; rrr_slam_offline does the same in line (no scan arrives meanwhile).
//
// What changes for the one who reads the map: the nodes and submaps are renumbered (the removed
// ones leave gaps that close up), and RRR decides the loops that are kept again from scratch.

#include <chrono>
#include <future>
#include <memory>
#include <vector>

#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_trimming.h"

namespace rrr_graphslam::frontend {

struct OnlineTrimParams {
  TrimParams trim;
  /// A trim every this many nodes of the session (0: none).
  int every_n_nodes = 0;
  /// true: the trim runs in the caller's thread, at once (offline replays: reproducible).
  bool in_line = false;
};

/// One online trim.
struct OnlineTrimRecord {
  std::size_t scan = 0;      ///< the caller's count of scans given when it started
  int nodes_before = 0;      ///< in the map at the checkpoint
  int nodes_after = 0;       ///< in the trimmed map, before the replay (nodes_before: no change)
  TrimReport report;         ///< the trim (report_kl off: an instrument, not part of a trim)
  double checkpoint_ms = 0;  ///< in the caller's thread
  double trim_ms = 0;        ///< trim and rebuild (in line: in the caller's thread)
  int replayed_scans = 0;    ///< the scans that came meanwhile, given to the trimmed map
  double replay_ms = 0;      ///< in the caller's thread
};

class OnlineTrimmer {
 public:
  /// Throws std::invalid_argument for trim parameters out of range, every_n_nodes < 0, or
  /// sparsification delete (deletion would drop the running session's folded loops to the map
  /// and could cut it loose while it counts as tied; clt and dense keep them).
  explicit OnlineTrimmer(const OnlineTrimParams& params);
  /// Waits for a trim in flight (its result is dropped).
  ~OnlineTrimmer();
  OnlineTrimmer(const OnlineTrimmer&) = delete;
  OnlineTrimmer& operator=(const OnlineTrimmer&) = delete;

  /// After each scan given to `slam`, refused or not (`node`: the node it became). Starts a trim
  /// when one is due; when one has finished, returns the LaserSlam that replaces `slam` (the
  /// scans given since the checkpoint given to it too), else nullptr.
  std::unique_ptr<LaserSlam> afterScan(LaserSlam& slam, const RangeScan& scan,
                                       const core::Pose2& odom_pose, std::optional<int> node);
  /// Without a scan (the robot stands still): what replaces the running map if the trim in
  /// flight has finished (as afterScan), else nullptr.
  std::unique_ptr<LaserSlam> poll();
  /// Waits for a trim in flight and returns what replaces the running map, or nullptr.
  std::unique_ptr<LaserSlam> wait();
  /// The running map was replaced otherwise (a map loaded, a reset, RRR decided again, a
  /// relocalization hint): a trim in flight, made from the map before, is dropped.
  void drop();
  bool inFlight() const { return pending_.valid(); }

  /// Trims finished, and those of them that replaced the map (the others found nothing).
  int finished() const { return finished_; }
  int replaced() const { return replaced_; }
  /// The last trim finished (nullptr before the first).
  const OnlineTrimRecord* last() const { return finished_ > 0 ? &last_ : nullptr; }

 private:
  struct Outcome {
    LaserSlam::Trimmed trimmed;
    double ms = 0.0;
  };
  bool due(const LaserSlam& slam) const;
  std::unique_ptr<LaserSlam> finish(Outcome outcome);

  OnlineTrimParams params_;
  std::size_t scans_ = 0;
  int session_nodes_ = 0;  // nodes the session made (its node numbers change with each trim)
  std::future<Outcome> pending_;
  OnlineTrimRecord in_flight_;
  struct Given {
    RangeScan scan;
    core::Pose2 odom_pose;
  };
  std::vector<Given> since_checkpoint_;
  int finished_ = 0;
  int replaced_ = 0;
  OnlineTrimRecord last_;
};

}  // namespace rrr_graphslam::frontend
