#pragma once
// Loop-candidate search (Hess et al., ICRA 2016, section V): a node is matched against a finished
// submap by branch-and-bound in a window around where the current map estimate puts it, then
// refined by least squares; a match above min_score becomes a loop candidate between the submap's
// node nearest to the match (not its anchor: local SLAM's drift within the submap stays out of
// the constraint) and the node, with the information matrix of the refinement. The front end
// proposes liberally; RRR decides.

#include <optional>

#include "rrr_graphslam/frontend/map_agreement.h"
#include "rrr_graphslam/frontend/scan_matcher.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

struct LoopSearchParams {
  /// Submaps whose anchor is farther than this from the node (map estimate) are not searched.
  double max_constraint_distance_m = 15.0;
  SearchWindow window;  ///< 7 m, 30 degrees
  double min_score = 0.6;
  /// Submaps holding any of the last min_node_separation nodes are local SLAM's business.
  int min_node_separation = 100;
  /// Points farther than this from the robot are left out of the search: the angular step of
  /// branch and bound shrinks with the farthest point, and its cost grows with it.
  double max_point_range_m = 15.0;
  /// A submap is searched by at most every n-th node (Cartographer's per-submap sampling, ratio
  /// 1/n). Default 4: with 120-scan submaps a place is covered by twice as many submaps as with
  /// 240, which together are searched as often as before.
  int search_every_n_nodes = 4;
  /// After a match, a submap rests for this many nodes (they would tell RRR the same thing).
  int pause_after_match_nodes = 10;
  /// Branch and bound scores a thinned scan: the coarsest voxel up to search_voxel_max_m that
  /// leaves search_min_points points (Cartographer's adaptive voxel filter; it uses 0.9 m / 100;
  /// 150 here thins 180-beam scans a little and 360-beam ones by about half); the
  /// least-squares refinement uses every point. search_min_points 0 turns the thinning off.
  double search_voxel_max_m = 0.9;
  int search_min_points = 150;
  /// Threads matching one node against its submaps (OpenMP).
  int threads = 2;
  /// While a session is not tied to the map it continues, every N-th of its nodes is matched
  /// against every submap of the earlier sessions, whole; default 5.
  int relocalization_every_n_nodes = 5;
  /// While a session is not tied: after this many nodes matched the earlier sessions, RRR decides
  /// their cluster at once and their search rests for cluster_gap + 1 nodes, so that the next
  /// matches make a cluster of their own; default 3.
  int relocalization_matches = 3;
  /// A session counts as tied to the map once its accepted loops to the earlier sessions lie at
  /// least this far apart along its own path (m): one place alone can match the wrong corridor of
  /// a building, self-consistently, with nothing in the graph to contradict it. RRR ties a
  /// session only so (LaserSlam sets RrrParams::placement_min_spread_m to it): until a group of
  /// agreeing loops this far apart exists they wait, and the whole-map search goes on; default
  /// 10 m.
  double relocalization_confirm_distance_m = 10.0;
  /// While a session is not tied: a match to an earlier session is not proposed when the
  /// session's scans over the last relocalization_check_travel_m of its path, placed where the
  /// match puts them, end in space the map has seen free for more than this fraction of their
  /// points on observed cells (map_agreement.h); 1 proposes every match. Default 0.06: true
  /// matches of ACES and Intel sessions 0.03 at most, ACES's 180-degree aliased ones 0.08 and
  /// more (doc/benchmarks.md#sessions).
  double relocalization_max_conflict = 0.06;
  /// m of the session's path, back from the matched node, whose scans the check places (the
  /// session's own drift grows with it); default 50.
  double relocalization_check_travel_m = 50.0;
  /// Once a session is tied: a second reading of where it lies (the building seen from its other
  /// end, the next corridor), beyond the search window around the tied one, that at least this
  /// many of its unaccepted loops to the earlier sessions agree on, and a quarter as many as the
  /// tied reading's accepted ones, is searched too, around where it puts each node
  /// (rival_reading.h). Both readings keep gathering loops as long as they fit, and
  /// RRR's decisions from scratch (its rebatches, the end) place the session by the one seen over
  /// the longer stretch (doc/rrr_extensions.md#the-wider-reading). 0: off; default 5.
  int rival_min_loops = 5;
  /// A match is not proposed when a distinct pose of the same search (farther than
  /// ambiguity_exclusion from it) scores more than ambiguity_ratio times its score: the scan alone
  /// cannot tell the two places apart (a corridor read a few metres along, a room like the next,
  /// a building read from its other end). 1: off.
  double ambiguity_ratio = 1.0;
  /// Poses within this of a match (translation and rotation) are the match's own place.
  SearchWindow ambiguity_exclusion{1.0, 0.2};
  MapAgreementParams agreement;
  /// Least-squares refinement of a match (weak pull toward the branch-and-bound pose).
  LeastSquaresParams refinement{1.0, 1.0, 1.0, 20, {0.05, 0.05, 0.5 * M_PI / 180}};
};

struct LoopMatch {
  int submap;
  int from;                     ///< the submap's node nearest to the match
  int to;                       ///< the node
  core::Pose2 measurement;      ///< pose of `to` in the frame of `from`
  Eigen::Matrix3d information;  ///< of `measurement`
  double score;                 ///< branch-and-bound score in [0, 1]
};

/// A node's scan as the loop search reads it: every point (least-squares refinement) and the
/// points branch and bound scores (thinned by the adaptive voxel filter). Built once per node and
/// shared by the searches of all its submaps.
struct LoopSearchScan {
  PointCloud points;
  PointCloud search_points;
};
LoopSearchScan loopSearchScan(PointCloud points, const LoopSearchParams& params);

/// What one search of a submap found.
struct SubmapSearch {
  std::optional<LoopMatch> loop;  ///< nothing when no pose scored above min_score, or ambiguous
  /// When the best pose was ambiguous (not proposed): the distinct pose that scored nearly as
  /// well (LoopSearchParams::ambiguity_ratio).
  std::optional<ScanMatch> alias;
};

/// `initial` is the node's guessed pose in the submap frame; no loop if nothing scores above
/// min_score in the window (or the submap is not finished).
SubmapSearch matchNodeToSubmap(const Submap& submap, int node, const LoopSearchScan& scan,
                               const core::Pose2& initial, const LoopSearchParams& params);

/// Relocalization: the whole submap, every rotation.
SubmapSearch matchNodeToWholeSubmap(const Submap& submap, int node, const LoopSearchScan& scan,
                                    const LoopSearchParams& params);

}  // namespace rrr_graphslam::frontend
