#pragma once
// The map file (*.rrrmap): everything a later run needs to continue a laser-SLAM map or localize
// in it: the parameters it was made with, its sessions, every node (session, timestamp,
// odometry-frame and map poses, its scan), every edge with its kind and RRR's verdict, and the
// submaps as the nodes that built them (rebuilt exactly by inserting those scans again).
//
// Layout (doc/design.md, "The map file"): an 8-byte magic "RRRMAP\n\0", the format version
// (uint32), the payload's size and its compressed size (uint64 each), the CRC-32 of the
// compressed payload (uint32), then the payload compressed with zlib. The payload is a sequence
// of little-endian records whose every length is checked against the bytes left before anything
// is allocated.
// Files are written atomically and read all or nothing: a truncated, corrupted, unknown or newer
// file is an InputError naming the file and what is wrong.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mrpt/obs/CObservation2DRangeScan.h>
#include <Eigen/Core>

#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::frontend {

/// The format version this build writes; it reads versions 1 to this one.
constexpr std::uint32_t kMapFormatVersion = 1;

/// What a map file holds. Node k has id k; sessions' nodes are consecutive.
struct MapSnapshot {
  struct Session {
    std::string name;
    double start_time = 0.0;  ///< the first node's timestamp
    int first_node = 0;
  };
  struct Node {
    int session = 0;
    double timestamp = 0.0;
    core::Pose2 local_pose = core::Pose2::Zero();  ///< in its session's odometry (local SLAM) frame
    core::Pose2 map_pose = core::Pose2::Zero();    ///< in the map frame, when saved
    std::shared_ptr<const mrpt::obs::CObservation2DRangeScan> scan;
  };
  /// Edge kinds in the file; kMarginal is reserved for the lifelong work's marginal factors.
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
  };
  /// A submap: the nodes first_node..last_node inserted in order at their local poses.
  struct Submap {
    int first_node = 0;
    int last_node = 0;
  };

  std::uint32_t format_version = kMapFormatVersion;
  /// Every parameter it was made with, as `name` = value text (the parameter tables).
  std::vector<std::pair<std::string, std::string>> params;
  std::vector<Session> sessions;
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Submap> submaps;

  /// Throws std::invalid_argument naming the first inconsistency (node indices out of range,
  /// sessions out of order, a node without a scan, ...).
  void check() const;
};

/// Writes `map` to `path` atomically. Throws std::runtime_error naming the path.
void writeMapFile(const MapSnapshot& map, const std::string& path);
/// Reads a map file. Throws core::InputError naming the file and what is wrong.
MapSnapshot readMapFile(const std::string& path);

/// The graph of the map: nodes at their map poses, odometry and loop candidates in file order.
core::PoseGraph mapPoseGraph(const MapSnapshot& map);

}  // namespace rrr_graphslam::frontend
