#pragma once
// 2D laser SLAM: local SLAM builds nodes and submaps, the loop search proposes candidates between
// nodes and finished submaps, and RRR (rrr::OnlineRrr, the same object the nodelet uses) decides
// which of them the map keeps. rrr_slam_offline and the nodelet's slam mode both drive this class.
//
// Graph: node k is the k-th scan the motion filter let through; odometry edges join consecutive
// nodes with the local-SLAM relative pose; loop candidates join a submap's anchor node to the
// matched node. Every scan (node or not) keeps its pose relative to the newest node at its time,
// so the whole trajectory follows the optimized nodes.
//
// Sessions: a map saved by snapshot() (map_file.h) is continued by fromMap() as a new session in
// its own odometry frame. Until it is tied to the earlier sessions, every
// relocalization_every_n_nodes-th node is matched against every submap of the earlier sessions,
// whole (branch and bound over the submap and all rotations); a match whose placement of the
// session's recent path conflicts with the map's free space is dropped (map_agreement.h); RRR
// decides the others like any loop, so one wrong relocalization cannot bend the map. RRR ties the
// session only through a group of agreeing loops to the earlier sessions at places of the session
// at least relocalization_confirm_distance apart along its path (rrr/session_placement.h): at one
// place only, nothing in the graph can contradict a self-consistent match with the wrong one of
// two alike corridors (the first link between two sessions closes no cycle). Should a later
// decision keep loops that place the session without tying it, its nodes are also searched
// around where they place it. Once tied, a rival reading that rival_min_loops unaccepted loops
// agree on is searched as well (rivalReading), so RRR's later decisions from scratch can still
// place the session by whichever reading gathers more loops. Parts of the map a tied session is
// not joined to (an earlier session that never tied, and nothing tied to it since) go on being
// searched whole on the same schedule: where the session passes where such a part was, RRR joins
// it to the map through a group of agreeing loops, as it places a session.

#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/maps/COccupancyGridMap2D.h>

#include "rrr_graphslam/frontend/laser_slam_params.h"
#include "rrr_graphslam/frontend/local_slam.h"
#include "rrr_graphslam/frontend/loop_search.h"
#include "rrr_graphslam/frontend/map_render.h"
#include "rrr_graphslam/frontend/map_snapshot.h"
#include "rrr_graphslam/frontend/map_trimming.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::frontend {

/// What a session continuing a loaded map does with it.
enum class SessionMode {
  kMapping,       ///< extends the map: its nodes, submaps and loops join it
  kLocalization,  ///< tracks the robot in the map, which stays as it was loaded
};

/// Counters for progress lines and benchmarks.
struct LaserSlamStats {
  int scans = 0;
  int matched_scans = 0;
  /// Scans matched in the window around the constant-velocity prediction, which scored better
  /// than the odometry's (LocalSlamParams::velocity_prediction): where the odometry was wrong.
  int velocity_predicted_scans = 0;
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
  int refused_candidates = 0;  ///< matches OnlineRrr refused (not positive definite, duplicates)
  long long relocalization_searches = 0;  ///< node-submap pairs searched whole (untied session)
  /// Matches to earlier sessions not proposed: the session's path they place conflicts with the
  /// map (relocalization_max_conflict).
  int contradicted_matches = 0;
  /// Matches not proposed: a distinct pose of the same search scored nearly as well
  /// (LoopSearchParams::ambiguity_ratio).
  int ambiguous_matches = 0;
  long long rival_searches = 0;  ///< node-submap pairs searched around a rival reading
};

/// A scan from another sensor setup than the loaded map's (SensorSetup): the run cannot continue
/// the map with it. The message names both setups.
class SensorMismatch : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class LaserSlam {
 public:
  /// A new map; its first session is named `session_name`.
  explicit LaserSlam(const LaserSlamParams& params = {}, const std::string& session_name = "");

  /// Continues `map` (read by readMapFile): its submaps are rebuilt from their nodes' scans and
  /// the next scan starts session `session_name`. Mapping: its nodes, edges and RRR's decisions
  /// are restored (RRR decides the loaded candidates again with `params`). Localization: its
  /// nodes are held fixed at their map poses (joined by rigid links, so RRR's tests see the map's
  /// own geometry) and only the new session's loops to them are decided; the session keeps no
  /// submap and no scan, and snapshot() refuses. Throws std::invalid_argument when the map cannot
  /// be continued with `params` (a parameter the submaps depend on differs: named) or is
  /// inconsistent.
  static std::unique_ptr<LaserSlam> fromMap(const MapSnapshot& map, const LaserSlamParams& params,
                                            const std::string& session_name,
                                            SessionMode mode = SessionMode::kMapping);
  /// Everything fromMap() needs, the current session's unfinished submaps included (they are
  /// rebuilt finished), and every parameter of both tables it runs with. Throws std::logic_error
  /// in localization (the loaded map is what there is to save).
  MapSnapshot snapshot() const;
  SessionMode mode() const { return mode_; }
  /// Every parameter of both tables it runs with, as a map file records them (name, value).
  std::vector<std::pair<std::string, std::string>> snapshotParams() const;

  /// Online trimming (map_trimming.h) while this session maps, in three steps so that the slow
  /// one runs off the thread that adds scans:
  ///   1. checkpoint(), on that thread: a copy of the map and of the session's state (the scans
  ///      shared, never written);
  ///   2. trimmed(checkpoint, ...), on any thread: trims the checkpoint's map with the current
  ///      session running (NewestSession::kRunning: with keep_current_session its submaps stay,
  ///      without it its older ones are judged against its newer ones; local SLAM's submaps and
  ///      those a loop in an open cluster touches wait) and builds the LaserSlam that continues
  ///      the same session from the trimmed map: the kept submaps rebuilt, RRR deciding the kept
  ///      candidates again (its open clusters stay open), local SLAM exactly where the checkpoint
  ///      left it. Nodes and submaps are renumbered after the removed ones; a scan of a removed
  ///      node of the session rides from then on with the kept node nearest along its path (as the
  ///      checkpoint's map placed them). The new RRR's verdicts are news (takeChanges: every
  ///      decided candidate, numbered as in the trimmed map);
  ///   3. the scans added here since the checkpoint are added to the new one, which replaces this.
  /// Nothing is trimmed while trimsWhileMapping() is false.
  /// Throws std::logic_error in localization or before the current session has a node.
  struct Checkpoint;
  Checkpoint checkpoint() const;
  struct Trimmed {
    std::unique_ptr<LaserSlam> slam;  ///< nullptr when nothing was trimmed
    TrimReport report;
  };
  /// Whether online trimming with `params` may trim now: once the session is tied to the map
  /// (before, where it covers the map is not known; once accepted loops of it to the map are
  /// folded into marginal constraints it stays tied), or in the map's first session when
  /// keep_current_session is off (it trims its own older submaps). Mapping mode only.
  bool trimsWhileMapping(const TrimParams& params) const;
  static Trimmed trimmed(const Checkpoint& checkpoint, const TrimParams& params,
                         const TrimmingStrategy& strategy);

  /// One scan with the robot's odometry pose at its time. Returns the node it became, if any.
  /// Throws ScanRefused (local_slam.h) for a scan it cannot place; the run goes on. Throws
  /// SensorMismatch when the session's first scan comes from another sensor setup than the
  /// loaded map's scans.
  std::optional<int> addScan(const RangeScan& scan, const core::Pose2& odom_pose);
  /// End of the run: RRR decides every cluster from scratch.
  void finish();
  /// A loop candidate from outside the loop search (a place recognizer, a fiducial, a
  /// benchmark's injected false loop), `measurement` the pose of `to` in the frame of `from`:
  /// RRR decides it like the search's own, and once accepted a loop between the current session
  /// and an earlier one counts toward the tie. Returns false when RRR refuses it (an unknown
  /// node, information not positive definite, a duplicate): counted in
  /// stats().refused_candidates. `source` is what the map file records of it.
  bool addCandidate(int from, int to, const core::Pose2& measurement,
                    const Eigen::Matrix3d& information, LoopSource source = LoopSource::kExternal);

  const rrr::OnlineRrr& rrr() const { return *rrr_; }
  rrr::OnlineRrr& rrr() { return *rrr_; }
  /// Which search proposed RRR's candidate `candidate` (its arrival index, as in rrr()): what the
  /// map file records of it; kExternal for one RRR took from outside since the last scan.
  /// std::out_of_range for an index RRR does not have.
  LoopSource candidateSource(int candidate) const;
  const LaserSlamStats& stats() const { return stats_; }
  const LaserSlamParams& params() const { return params_; }

  /// A hint for relocalization: the robot is at `map_pose` (map frame) now, i.e. at the current
  /// session's newest node, or at its first node if it has none yet. Until the session is tied,
  /// its searches of the earlier sessions' submaps then start from where the hint puts each node
  /// (the usual window, linear_search_window and angular_search_window) instead of searching them
  /// whole. It only guides the search: the loops found are decided by RRR like any other. Throws
  /// std::logic_error in the first session (there is no map to be placed in).
  void setInitialPose(const core::Pose2& map_pose);

  /// The sessions so far; the last is the current one.
  const std::vector<MapSnapshot::Session>& sessions() const { return sessions_; }
  /// When the current session was first tied to the earlier ones, if it was; nullopt for the
  /// first session.
  struct Tie {
    int node;          ///< the node it was tied at (a later trim that removes it: the next kept)
    int session_node;  ///< that node's number in the session at the time (0: its first)
    double timestamp;  ///< of that node
  };
  const std::optional<Tie>& tie() const { return tie_; }
  /// Whether the loops RRR accepts now between the current session and the earlier ones lie at
  /// least relocalization_confirm_distance apart along the session's path.
  bool tied() const;
  /// Whether RRR accepts any loop between the current session and the earlier ones now (the
  /// session is placed in the map, tied or not yet).
  bool placed() const;
  /// Travel along the current session (m) between the first and the last of its nodes that loops
  /// RRR accepts join to the earlier sessions; -infinity if there are none.
  double acceptedCrossingSpread() const;
  /// Index in scanMapPoses() of the current session's first scan (0 in the first session).
  std::size_t sessionFirstScan() const { return session_first_scan_; }
  /// What lifelong trimming removed from the map over its life, as loaded (map_trimming.h).
  const MapSnapshot::Lifelong& lifelong() const { return lifelong_; }
  /// The cells trimmed submaps decided that the rendered map keeps (map_memory.h), as loaded.
  const std::vector<RememberedCells>& memory() const { return memory_; }
  /// Timestamp of every node.
  const std::vector<double>& nodeTimestamps() const { return node_timestamps_; }
  /// The index in sessions() of every node's session.
  std::vector<int> nodeSessions() const;

  /// Map pose of every scan so far (log order), following the current node estimates. Nodes of
  /// loaded sessions count as one scan each.
  std::vector<core::Pose2> scanMapPoses() const;
  /// Timestamps of every scan so far.
  const std::vector<double>& scanTimestamps() const { return scan_timestamps_; }
  /// What the occupancy map is made of now (the scans shared, not copied); in localization, the
  /// loaded map's nodes only.
  MapInputs mapInputs() const;
  /// The occupancy map: every node's scan inserted at its map pose (layered and weighed as
  /// map_render.h says; without `render`, as the submaps weigh a ray).
  mrpt::maps::COccupancyGridMap2D renderMap(
      double resolution_m, MapLayering layering = MapLayering::kAllScans,
      const std::optional<MapRenderParams>& render = std::nullopt) const {
    MapInputs inputs = mapInputs();
    inputs.layering = layering;
    inputs.render = render;
    return renderOccupancyMap(inputs, resolution_m);
  }

 private:
  /// fromMap()'s loading: nodes, edges (RRR deciding the candidates again, or the map held fixed
  /// in localization), lifelong record and the first `finished_submaps` submaps rebuilt finished.
  /// `continuing` (trimmed()): the clusters open at the map's last node stay open, and RRR's
  /// verdicts are news (under the trimmed map's numbering).
  void load(const MapSnapshot& map, std::size_t finished_submaps, bool continuing = false);
  static bool trimsWhileMapping(bool tied, std::size_t sessions, const TrimParams& params);
  void searchLoops(int node, const PointCloud& points);
  // Records the candidates RRR took without addCandidate (candidate_source_).
  void adoptCandidatesFromOutside();
  // Adds RRR's candidate to crossing_ if it joins the current session to an earlier one.
  void noteCrossing(int candidate);
  /// Keeps a thinned copy of the node's scan while its session is not tied (or a rival reading
  /// may be searched), over the last relocalization_check_travel_m of the path.
  void keepSessionPoints(int node, const PointCloud& points);
  /// The map agreement (map_agreement.h) of the session's kept scans placed by `loop` (a match
  /// of the newest node to an earlier session's submap); `map` the earlier sessions' submaps.
  MapAgreement sessionAgreement(const LoopMatch& loop, const std::vector<core::Pose2>& poses,
                                const std::vector<PlacedSubmap>& map) const;
  /// Where the largest group of the current session's unaccepted loops to the earlier sessions
  /// puts `node` (rival_reading.h), if at least rival_min_loops of them agree there, leaving out
  /// those within the search window around where `map` has the node (its own search's).
  /// `part`: mapParts(), or empty when every earlier node is in the map's part.
  std::optional<core::Pose2> rivalReading(int node, const std::vector<core::Pose2>& map,
                                          const std::vector<std::size_t>& part) const;
  /// Per node, the part of the map it lies in (sessions that trusted constraints and accepted
  /// loops join, rrr::VerificationGraph::componentsJoinedBy); map poses of different parts are in
  /// unrelated frames.
  std::vector<std::size_t> mapParts() const;

  LaserSlamParams params_;
  SessionMode mode_ = SessionMode::kMapping;
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
  std::vector<SubmapSearchState> search_state_;        // by submap index
  std::vector<SubmapSearchState> rival_search_state_;  // the same, for the rival reading's searches
  LaserSlamStats stats_;
  std::vector<MapSnapshot::Session> sessions_;
  std::vector<double> node_timestamps_;
  std::vector<MapSnapshot::Submap> finished_spans_;  // nodes of each finished submap
  MapSnapshot::Lifelong lifelong_;                   // what trimming removed, as loaded
  std::vector<RememberedCells> memory_;              // the map's memory of trimmed submaps
  int session_first_submap_ = 0;  // submaps of earlier sessions have smaller indices
  std::size_t session_first_scan_ = 0;
  std::optional<Tie> tie_;
  bool tied_by_marginals_ = false;  // online trimming folded loops that tied the session
  struct Hint {
    int node;  // the node the hint places (-1: the session's first node, not there yet)
    core::Pose2 map_pose;
  };
  std::optional<Hint> hint_;
  std::optional<SensorSetup> map_sensor_;  // of the loaded map's scans, until a scan was checked
  int relocalization_matches_ = 0;         // nodes that matched the earlier sessions since the rest
  int relocalization_paused_until_ = 0;    // no whole-map search before this node
  int apart_matches_ = 0;                  // the same, for parts of the map not joined (mapParts)
  int apart_paused_until_ = 0;
  struct Crossing {
    int candidate;     // between this session and an earlier one
    int session_node;  // its end in this session
  };
  std::vector<Crossing> crossing_;
  // Per RRR candidate, in RRR's order. Candidates RRR took directly (rrr().addCandidate: the ROS
  // node's loop_candidates topic in scan mode) are adopted as kExternal before each scan, each
  // addCandidate and finish, and count toward the tie like the search's.
  std::vector<LoopSource> candidate_source_;
  std::vector<double> node_travel_;  // path length from the node's session start (m)
  struct KeptPoints {
    int node;
    PointCloud points;  // thinned, in the node's frame
  };
  std::deque<KeptPoints> session_points_;  // while matches to the map are checked

 public:
  /// LaserSlam's own state (see checkpoint()): what trimmed() continues from.
  struct Checkpoint {
    MapSnapshot map;  ///< snapshot()
    LaserSlamParams params;
    LocalSlam::Checkpoint local;
    std::vector<MapSnapshot::Session> sessions;
    int session_first_submap = 0;
    bool tied = false;
    bool tied_by_marginals = false;
    // The current session's scans (scan_node in the map's numbering).
    std::vector<int> scan_node;
    std::vector<core::Pose2> scan_offset;
    std::vector<double> scan_timestamps;
    std::vector<SubmapSearchState> search_state;
    std::vector<SubmapSearchState> rival_search_state;  // empty until a rival reading was searched
    LaserSlamStats stats;
    std::optional<Tie> tie;
    std::optional<SensorSetup> map_sensor;
    int relocalization_matches = 0;
    int relocalization_paused_until = 0;
    int apart_matches = 0;
    int apart_paused_until = 0;
    std::deque<KeptPoints> session_points;
    std::vector<double> session_travel;  // node_travel_ of the current session's nodes
  };
};

}  // namespace rrr_graphslam::frontend
