#pragma once
// What a map holds (MapSnapshot): everything a later run needs to continue a laser-SLAM map or
// localize in it: the parameters it was made with, its sessions, every node (session, timestamp,
// odometry-frame and map poses, its scan), every edge with its kind and RRR's verdict, the
// submaps as the nodes that built them (rebuilt exactly by inserting those scans again), what
// lifelong trimming left (marginal edges, dense factors, the memory of trimmed submaps), and the
// pose graphs it stands for. map_file.h writes and reads it (*.rrrmap).

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/obs/CObservation2DRangeScan.h>
#include <Eigen/Core>

#include "rrr_graphslam/core/dense_factor.h"
#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/map_memory.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::frontend {

/// The format version this build writes; it reads versions 1 to this one. Version 2 added
/// marginal edges and the lifelong counters (a version-1 map holds neither; it is read as is and
/// continued as the newest version); version 3 the sessions' numbers and the map's memory of
/// trimmed submaps (map_memory.h; an older map has none, and its sessions are numbered in order);
/// version 4 each loop candidate's source (older maps: unknown); version 5 the dense factors a
/// `dense` trim leaves (older maps have none); version 6 the rival search as a loop source (an
/// older map's rival-search loops are named local-search).
constexpr std::uint32_t kMapFormatVersion = 6;

/// The most nodes a dense factor in a map file may hold (its information is a dense 3(n-1)
/// square: 1.2 GB at this size). A trim whose blanket piece is larger cannot be saved with
/// `--sparsification dense`; a file that claims one is refused before anything is allocated.
constexpr std::size_t kMaxDenseFactorNodes = 4096;

/// Which search proposed a loop candidate.
enum class LoopSource : std::uint8_t {
  kUnknown = 0,         ///< a map written before version 4
  kLocalSearch = 1,     ///< a window around the node's estimated (or hinted) pose in the submap
  kWholeMapSearch = 2,  ///< relocalization: the whole submap, every rotation (an untied session)
  kInjected = 3,        ///< a false loop a test or benchmark added (rrr_slam_offline --false-loops)
  kExternal = 4,        ///< given from outside the loop search (LaserSlam::addCandidate)
  kRivalSearch = 5,     ///< a window around the rival reading of a tied session (version 6 on)
};
inline core::Choices<LoopSource> choices(LoopSource /*tag*/) {
  return {{LoopSource::kUnknown, "unknown"},
          {LoopSource::kLocalSearch, "local-search"},
          {LoopSource::kWholeMapSearch, "whole-map-search"},
          {LoopSource::kInjected, "injected"},
          {LoopSource::kExternal, "external"},
          {LoopSource::kRivalSearch, "rival-search"}};
}
/// "unknown", "local-search", "whole-map-search", "injected", "external", "rival-search".
std::string toString(LoopSource source);

/// What a map file holds. Node k has id k; sessions' nodes are consecutive.
struct MapSnapshot {
  struct Session {
    std::string name;
    double start_time = 0.0;  ///< the first node's timestamp
    int first_node = 0;
    /// The session's place in the map's life, kept when earlier sessions leave it whole
    /// (trimming): numbers grow with every session (version 3 on; older files: the index).
    int number = 0;
  };
  struct Node {
    int session = 0;
    double timestamp = 0.0;
    core::Pose2 local_pose = core::Pose2::Zero();  ///< in its session's odometry (local SLAM) frame
    core::Pose2 map_pose = core::Pose2::Zero();    ///< in the map frame, when saved
    std::shared_ptr<const mrpt::obs::CObservation2DRangeScan> scan;
  };
  /// Edge kinds in the file. kMarginal: a trusted constraint that replaced the constraints of
  /// nodes lifelong trimming removed (map_trimming.h), between any two nodes.
  enum class EdgeKind : std::uint8_t { kOdometry = 0, kLoopCandidate = 1, kMarginal = 2 };
  struct Edge {
    int from = 0;
    int to = 0;
    EdgeKind kind = EdgeKind::kOdometry;
    core::Pose2 measurement = core::Pose2::Zero();
    Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
    rrr::Verdict verdict = rrr::Verdict::kPending;  ///< loop candidates
    int cluster = -1;
    std::string reason;
    LoopSource source = LoopSource::kUnknown;  ///< loop candidates (version 4 on)
  };
  /// A submap: the nodes first_node..last_node inserted in order at their local poses.
  struct Submap {
    int first_node = 0;
    int last_node = 0;
  };
  /// What lifelong trimming removed over the map's life (version 2 on).
  struct Lifelong {
    int trimmed_submaps = 0;
    int marginalized_nodes = 0;
  };

  std::uint32_t format_version = kMapFormatVersion;
  /// Every parameter it was made with, as `name` = value text (the parameter tables).
  std::vector<std::pair<std::string, std::string>> params;
  std::vector<Session> sessions;
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Submap> submaps;
  Lifelong lifelong;
  /// Dense factors (core/dense_factor.h) over node indices, trusted like marginal edges: the exact
  /// marginals of trims with `sparsification dense` (version 5 on).
  std::vector<core::DenseFactor> dense_factors;
  /// Cells trimmed submaps decided that the rendered map keeps showing (version 3 on).
  std::vector<RememberedCells> memory;

  /// Throws std::invalid_argument naming the first inconsistency (node indices out of range,
  /// sessions out of order, a node without a scan, a version that cannot hold what the map
  /// holds, ...).
  void check() const;
};

/// The PoseGraph kind of a file's edge kind.
core::EdgeKind toCoreKind(MapSnapshot::EdgeKind kind);

/// The graph of the map: nodes at their map poses, its edges (odometry, marginal constraints and
/// loop candidates) in file order, and its dense factors.
core::PoseGraph mapPoseGraph(const MapSnapshot& map);

/// The same without the loop candidates RRR did not accept: the constraints the map's poses are
/// the optimum of (odometry, marginal constraints, dense factors, accepted loops).
core::PoseGraph trustedPoseGraph(const MapSnapshot& map);

}  // namespace rrr_graphslam::frontend
