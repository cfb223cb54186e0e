// Map files: a round trip keeps everything a later run needs; damaged files are refused naming
// the file and what is wrong; a new session continues a loaded map in its own odometry frame and
// is tied to it by RRR-accepted loops.

#include <gtest/gtest.h>

#include <dirent.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/map_payload.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

using testing::castScan;
using testing::drive;
using testing::room;
using testing::truthAt;

LaserSlamParams smallMaps() {
  LaserSlamParams p = testing::roomSizedParams();
  p.loops.relocalization_confirm_distance_m = 3.0;  // a third of a lap of the room
  return p;
}

std::string tempPath(const std::string& name) { return ::testing::TempDir() + name; }

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// One lap and a bit, saved: the map the tests continue.
const std::string& savedMap() {
  static const std::string path = [] {
    LaserSlam slam(smallMaps(), "first");
    drive(slam, core::Pose2::Zero(), 130, 0.0);
    slam.finish();
    const std::string p = tempPath("room.rrrmap");
    writeMapFile(slam.snapshot(), p);
    return p;
  }();
  return path;
}

TEST(MapFile, RoundTripKeepsEverythingAContinuationNeeds) {
  LaserSlam slam(smallMaps(), "first");
  drive(slam, core::Pose2::Zero(), 130, 0.0);
  slam.finish();
  const MapSnapshot saved = slam.snapshot();
  const std::string path = tempPath("roundtrip.rrrmap");
  writeMapFile(saved, path);
  const MapSnapshot read = readMapFile(path);

  EXPECT_EQ(read.format_version, kMapFormatVersion);
  EXPECT_EQ(read.params, saved.params);
  ASSERT_EQ(read.sessions.size(), 1u);
  EXPECT_EQ(read.sessions[0].name, "first");
  ASSERT_EQ(read.nodes.size(), saved.nodes.size());
  ASSERT_GT(read.nodes.size(), 50u);
  for (std::size_t k = 0; k < read.nodes.size(); ++k) {
    EXPECT_EQ(read.nodes[k].local_pose, saved.nodes[k].local_pose);
    EXPECT_EQ(read.nodes[k].map_pose, saved.nodes[k].map_pose);
    EXPECT_EQ(read.nodes[k].timestamp, saved.nodes[k].timestamp);
    EXPECT_EQ(read.nodes[k].scan->getScanRange(10), saved.nodes[k].scan->getScanRange(10));
    EXPECT_EQ(read.nodes[k].scan->getScanSize(), saved.nodes[k].scan->getScanSize());
  }
  ASSERT_EQ(read.edges.size(), saved.edges.size());
  int loops = 0;
  for (std::size_t k = 0; k < read.edges.size(); ++k) {
    EXPECT_EQ(read.edges[k].from, saved.edges[k].from);
    EXPECT_EQ(read.edges[k].kind, saved.edges[k].kind);
    EXPECT_EQ(read.edges[k].measurement, saved.edges[k].measurement);
    EXPECT_EQ(read.edges[k].information, saved.edges[k].information);
    EXPECT_EQ(read.edges[k].verdict, saved.edges[k].verdict);
    EXPECT_EQ(read.edges[k].reason, saved.edges[k].reason);
    EXPECT_EQ(read.edges[k].source, saved.edges[k].source);
    loops += read.edges[k].kind == MapSnapshot::EdgeKind::kLoopCandidate;
    // One session: every loop came from the search around the estimate.
    EXPECT_EQ(read.edges[k].source, read.edges[k].kind == MapSnapshot::EdgeKind::kLoopCandidate
                                        ? LoopSource::kLocalSearch
                                        : LoopSource::kUnknown);
  }
  EXPECT_GT(loops, 0) << "the lap closed no loop";
  ASSERT_EQ(read.submaps.size(), saved.submaps.size());

  // Loaded, RRR decides the same candidates the same way.
  const auto loaded = LaserSlam::fromMap(read, smallMaps(), "second");
  ASSERT_EQ(loaded->rrr().numCandidates(), loops);
  int k = 0;
  for (const auto& e : read.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate) {
      EXPECT_EQ(loaded->rrr().verdict(k++), e.verdict);
    }
  }
  // And saved again without a new node, it is the same map.
  const MapSnapshot again = loaded->snapshot();
  EXPECT_EQ(again.nodes.size(), read.nodes.size());
  EXPECT_EQ(again.submaps.size(), read.submaps.size());
  EXPECT_EQ(again.sessions.size(), 1u);  // the new session has no node yet
}

TEST(MapFile, DamagedFilesAreRefusedNamingFileAndFault) {
  const std::string good = readBytes(savedMap());
  auto refused = [&](const std::string& name, const std::string& bytes, const std::string& fault) {
    const std::string path = tempPath(name);
    writeBytes(path, bytes);
    try {
      readMapFile(path);
      ADD_FAILURE() << name << " accepted";
    } catch (const core::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(fault), std::string::npos) << e.what();
    }
  };
  refused("truncated.rrrmap", good.substr(0, good.size() / 2), "truncated");
  std::string flipped = good;
  flipped[flipped.size() / 2] ^= 0x10;
  refused("flipped.rrrmap", flipped, "checksum mismatch");
  std::string newer = good;
  newer[8] = 99;  // the version's low byte
  refused("newer.rrrmap", newer,
          "format version 99 is newer than this build reads (" + std::to_string(kMapFormatVersion) +
              ")");
  refused("text.rrrmap", "VERTEX_SE2 0 0 0 0\n", "not an rrr_graphslam map file");
  refused("empty.rrrmap", "", "not an rrr_graphslam map file");
  EXPECT_THROW(readMapFile(tempPath("does_not_exist.rrrmap")), core::InputError);
}

// What a map written before version 4 holds of its loops: no source.
void clearLoopSources(MapSnapshot& map) {
  for (MapSnapshot::Edge& e : map.edges) e.source = LoopSource::kUnknown;
}

TEST(MapFile, AVersionOneMapIsReadAsItIsAndContinuedAsTheNewest) {
  MapSnapshot old = readMapFile(savedMap());
  old.format_version = 1;
  clearLoopSources(old);
  const std::string path = tempPath("version1.rrrmap");
  writeMapFile(old, path);
  const std::string bytes = readBytes(path);
  ASSERT_GT(bytes.size(), 12u);
  EXPECT_EQ(bytes[8], 1);  // the header says version 1
  const MapSnapshot read = readMapFile(path);
  EXPECT_EQ(read.format_version, 1u);
  EXPECT_EQ(read.lifelong.trimmed_submaps, 0);
  EXPECT_EQ(read.nodes.size(), old.nodes.size());
  auto slam = LaserSlam::fromMap(read, smallMaps(), "next");
  EXPECT_EQ(slam->snapshot().format_version, kMapFormatVersion);
  // What version 1 cannot hold is refused when written as version 1.
  MapSnapshot marginal = old;
  marginal.edges.front().kind = MapSnapshot::EdgeKind::kMarginal;
  EXPECT_THROW(writeMapFile(marginal, tempPath("bad_version1.rrrmap")), std::invalid_argument);
  MapSnapshot counted = old;
  counted.lifelong.trimmed_submaps = 3;
  EXPECT_THROW(writeMapFile(counted, tempPath("bad_version1.rrrmap")), std::invalid_argument);
}

// `map` fails check() with a message holding `fault`, and is not written.
void expectRefused(const MapSnapshot& map, const std::string& fault) {
  try {
    map.check();
    ADD_FAILURE() << fault << ": accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fault), std::string::npos) << e.what();
  }
  EXPECT_THROW(writeMapFile(map, tempPath("refused.rrrmap")), std::invalid_argument);
}

// A patch of remembered cells (map_memory.h) anchored to node `anchor`.
RememberedCells patchAt(int anchor, int session) {
  RememberedCells patch;
  patch.session = session;
  patch.anchor_node = anchor;
  patch.origin = core::Pose2(0.5, -0.25, 0.1);
  patch.resolution_m = 0.05;
  patch.width = 3;
  patch.height = 2;
  patch.cells = std::make_shared<const std::vector<std::uint8_t>>(
      std::vector<std::uint8_t>{0, 1, 255, 200, 0, 17});
  return patch;
}

TEST(MapFile, VersionThreeKeepsSessionNumbersAndTheMemory) {
  MapSnapshot map = readMapFile(savedMap());
  ASSERT_EQ(map.format_version, kMapFormatVersion);
  ASSERT_EQ(map.sessions.size(), 1u);
  map.sessions[0].number = 7;  // six earlier sessions left the map whole
  map.memory = {patchAt(2, 3), patchAt(5, 7)};
  const std::string path = tempPath("version3.rrrmap");
  writeMapFile(map, path);
  const MapSnapshot read = readMapFile(path);
  EXPECT_EQ(read.sessions[0].number, 7);
  ASSERT_EQ(read.memory.size(), 2u);
  for (std::size_t p = 0; p < 2; ++p) {
    EXPECT_EQ(read.memory[p].session, map.memory[p].session);
    EXPECT_EQ(read.memory[p].anchor_node, map.memory[p].anchor_node);
    EXPECT_EQ(read.memory[p].origin, map.memory[p].origin);
    EXPECT_EQ(read.memory[p].resolution_m, 0.05);
    EXPECT_EQ(read.memory[p].width, 3);
    EXPECT_EQ(read.memory[p].height, 2);
    EXPECT_EQ(*read.memory[p].cells, *map.memory[p].cells);
  }
  EXPECT_EQ(rememberedCells(read.memory), 8u);
  // A continuation numbers its session after the map's newest and carries the memory on.
  auto slam = LaserSlam::fromMap(read, smallMaps(), "next");
  EXPECT_EQ(slam->sessions().back().number, 8);
  drive(*slam, core::Pose2(1.0, 2.0, 0.3), 40, 500.0);
  const MapSnapshot continued = slam->snapshot();
  EXPECT_EQ(continued.sessions.back().number, 8);
  EXPECT_EQ(rememberedCells(continued.memory), 8u);

  // Version 2 numbers its sessions in order and holds no memory: written as version 2, the
  // numbers are refused unless they are the indices, and so is a memory.
  MapSnapshot two = readMapFile(savedMap());
  two.format_version = 2;
  clearLoopSources(two);
  writeMapFile(two, tempPath("version2.rrrmap"));
  const MapSnapshot read2 = readMapFile(tempPath("version2.rrrmap"));
  EXPECT_EQ(read2.format_version, 2u);
  EXPECT_EQ(read2.sessions[0].number, 0);
  EXPECT_TRUE(read2.memory.empty());
  MapSnapshot numbered = two;
  numbered.sessions[0].number = 4;
  expectRefused(numbered, "session 0 has number 4, which format version 2 cannot hold");
  MapSnapshot remembering = two;
  remembering.memory = {patchAt(2, 0)};
  expectRefused(remembering, "format version 2 cannot hold the memory of trimmed submaps");

  // Version 3 holds no loop sources: read as unknown, refused when written.
  MapSnapshot three = readMapFile(savedMap());
  three.format_version = 3;
  expectRefused(three, "has a loop source, which format version 3 cannot hold");
  clearLoopSources(three);
  writeMapFile(three, tempPath("version3_sources.rrrmap"));
  const MapSnapshot read3 = readMapFile(tempPath("version3_sources.rrrmap"));
  EXPECT_EQ(read3.format_version, 3u);
  EXPECT_EQ(read3.edges.size(), three.edges.size());
  auto continued3 = LaserSlam::fromMap(read3, smallMaps(), "after three");
  for (const MapSnapshot::Edge& e : continued3->snapshot().edges) {
    EXPECT_EQ(e.source, LoopSource::kUnknown);
  }
  MapSnapshot odd = readMapFile(savedMap());
  odd.edges.front().source = LoopSource::kInjected;  // an odometry edge
  expectRefused(odd, "has a loop source but is no loop candidate");

  // Version 6 names the rival search's loops; version 5 cannot.
  MapSnapshot rival = readMapFile(savedMap());
  const auto loop = std::find_if(rival.edges.begin(), rival.edges.end(), [](const auto& e) {
    return e.kind == MapSnapshot::EdgeKind::kLoopCandidate;
  });
  ASSERT_NE(loop, rival.edges.end());
  loop->source = LoopSource::kRivalSearch;
  writeMapFile(rival, tempPath("rival_source.rrrmap"));
  const MapSnapshot read6 = readMapFile(tempPath("rival_source.rrrmap"));
  EXPECT_EQ(read6.edges[static_cast<std::size_t>(loop - rival.edges.begin())].source,
            LoopSource::kRivalSearch);
  EXPECT_EQ(toString(LoopSource::kRivalSearch), "rival-search");
  // A version-5 file holding one (written by hand: the writer refuses it) is refused when read.
  const std::string payload = encodeMapPayload(rival);
  try {
    decodeMapPayload(std::vector<std::uint8_t>(payload.begin(), payload.end()), 5);
    ADD_FAILURE() << "a rival-search loop read from a version-5 payload";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("loop source 5 is unknown"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(decodeMapPayload(std::vector<std::uint8_t>(payload.begin(), payload.end()), 6)
                .edges[static_cast<std::size_t>(loop - rival.edges.begin())]
                .source,
            LoopSource::kRivalSearch);
  rival.format_version = 5;
  expectRefused(rival, "comes from the rival search, which format version 5 cannot name");

  // Broken memory and numbers in a version-3 map.
  MapSnapshot bad = map;
  bad.memory[1].anchor_node = static_cast<int>(map.nodes.size());
  expectRefused(bad, "remembered patch 1: its anchor node");
  bad = map;
  bad.memory[0].width = 4;
  expectRefused(bad, "remembered patch 0: it holds 6 cells, not 4 x 2");
  bad = map;
  bad.memory[0].resolution_m = std::nan("");
  expectRefused(bad, "remembered patch 0: its resolution");
  bad = map;
  bad.memory[0].origin.x() = 1e300;
  expectRefused(bad, "remembered patch 0: it lies beyond 1e6 m of its anchor");
  bad = map;
  bad.memory[0].resolution_m = 5.0;  // 300 cells of 5 m: no tile is that large
  bad.memory[0].width = 300;
  bad.memory[0].cells = std::make_shared<const std::vector<std::uint8_t>>(600, 1);
  expectRefused(bad,
                "remembered patch 0: it lies beyond 1e6 m of its anchor or spans more than 1 km");
  bad = map;
  bad.memory[0].resolution_m = 1e-6;
  expectRefused(bad, "remembered patch 0: its resolution 0.000001 m is not in [0.001, 10]");
  bad = map;
  bad.memory[0].width = bad.memory[0].height = 5000;
  expectRefused(bad, "remembered patch 0: its size 5000 x 5000 cells is not positive or above");
  bad = map;
  bad.sessions[0].number = 2'000'000'000;
  expectRefused(bad, "session 0 has number 2000000000");
  bad = map;
  bad.memory[1].session = 8;
  expectRefused(bad, "remembered patch 1: its session 8 is newer than the map's newest");
  bad = map;
  bad.sessions[0].number = -1;
  expectRefused(bad, "session 0 has number -1, not above the session before's");
}

TEST(MapFile, ImplausibleContentIsRefusedBeforeAnyGridIsBuiltFromIt) {
  // What local SLAM refuses live (ScanRefused) is refused in a file too: a grid rebuilt from it
  // would try to grow to 1e300 m.
  const MapSnapshot good = readMapFile(savedMap());
  MapSnapshot far = good;
  far.nodes[3].map_pose.x() = 1e300;
  expectRefused(far, "node 3 has a pose beyond 1e6 m");
  MapSnapshot laser = good;
  auto moved = std::make_shared<mrpt::obs::CObservation2DRangeScan>(*good.nodes[2].scan);
  moved->sensorPose.x(1e300);
  laser.nodes[2].scan = moved;
  expectRefused(laser, "node 2's scan has its laser more than 100 m from the robot");
  MapSnapshot reading = good;
  auto nan = std::make_shared<mrpt::obs::CObservation2DRangeScan>(*good.nodes[1].scan);
  nan->setScanRange(0, std::nanf(""));
  nan->setScanRangeValidity(0, true);
  reading.nodes[1].scan = nan;
  expectRefused(reading, "node 1's scan has a valid reading outside [0, maxRange]");
  // A map without nodes is not saved.
  EXPECT_THROW(LaserSlam(smallMaps()).snapshot(), std::invalid_argument);
  // Dense factors (version 5): over nodes of the map, and sound.
  core::DenseFactor f;
  f.nodes = {2, 5};
  f.measurements = {core::between(good.nodes[2].map_pose, good.nodes[5].map_pose)};
  f.mean = Eigen::Vector3d::Zero();
  f.information = Eigen::Matrix3d::Identity();
  MapSnapshot dense = good;
  dense.dense_factors.push_back(f);
  const std::string path = tempPath("dense_factor.rrrmap");
  writeMapFile(dense, path);
  const MapSnapshot read = readMapFile(path);
  ASSERT_EQ(read.dense_factors.size(), 1u);
  EXPECT_EQ(read.dense_factors[0].nodes, f.nodes);
  EXPECT_EQ(read.dense_factors[0].information, f.information);
  EXPECT_EQ(trustedPoseGraph(read).denseFactors().size(), 1u);
  MapSnapshot outside = dense;
  outside.dense_factors[0].nodes[1] = static_cast<mrpt::graphs::TNodeID>(good.nodes.size());
  expectRefused(outside, "dense factor 0 holds node " + std::to_string(good.nodes.size()));
  MapSnapshot unsound = dense;
  unsound.dense_factors[0].information(2, 2) = -1.0;
  expectRefused(unsound, "dense factor 0: its information is not positive definite");
  MapSnapshot older = dense;
  older.format_version = 4;
  expectRefused(older, "format version 4 cannot hold dense factors");
  MapSnapshot huge = dense;  // refused by its size before anything looks inside it
  huge.dense_factors[0].nodes.assign(kMaxDenseFactorNodes + 1, 0);
  expectRefused(huge, "more than the " + std::to_string(kMaxDenseFactorNodes));
}

TEST(MapFile, AMapMadeWithOtherSubmapsIsRefusedNamingTheParameter) {
  LaserSlamParams other = smallMaps();
  other.local.submap.resolution_m = 0.1;
  try {
    LaserSlam::fromMap(readMapFile(savedMap()), other, "second");
    FAIL() << "a 0.05 m map continued with 0.1 m submaps";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("submap_resolution is 0.1 here but the map was made "
                                         "with 0.05"),
              std::string::npos)
        << e.what();
  }
}

TEST(MapFile, ScansFromAnotherSensorSetupAreRefusedNamingBothSetups) {
  const MapSnapshot map = readMapFile(savedMap());
  auto slam = LaserSlam::fromMap(map, smallMaps(), "second");
  const std::size_t nodes = slam->rrr().numNodes();
  const RangeScan same = castScan(room(), truthAt(0));
  auto refused = [&](RangeScan scan, const std::string& expected) {
    try {
      slam->addScan(scan, truthAt(0));
      ADD_FAILURE() << "continued with " << SensorSetup::of(scan).describe();
    } catch (const SensorMismatch& e) {
      EXPECT_NE(std::string(e.what()).find("the scan's laser has " + expected), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("the map's scans have 360 beams 1.000 deg apart over "
                                           "360.00 deg, centred at 0.00 deg, at (0.000, 0.000) m"),
                std::string::npos)
          << e.what();
    }
  };
  RangeScan half = same;  // every other beam: half the resolution
  half.ranges.resize(180);
  half.angle_increment *= 2.0;
  for (int i = 0; i < 180; ++i) half.ranges[static_cast<std::size_t>(i)] = same.ranges[2 * i];
  refused(half, "180 beams 2.000 deg apart over 360.00 deg");
  RangeScan narrow = same;  // a 270-degree sensor
  narrow.ranges.resize(270);
  refused(narrow, "270 beams 1.000 deg apart over 270.00 deg");
  RangeScan moved = same;  // mounted 0.2 m forward
  moved.laser_in_robot = core::Pose2(0.2, 0.0, 0.0);
  refused(moved,
          "360 beams 1.000 deg apart over 360.00 deg, centred at 0.00 deg, at (0.200, "
          "0.000) m");
  EXPECT_EQ(static_cast<std::size_t>(slam->rrr().numNodes()), nodes) << "nothing was added";
  // An implausible laser pose is local SLAM's to refuse, as without a map.
  RangeScan nowhere = same;
  nowhere.laser_in_robot = core::Pose2(std::nan(""), 0.0, 0.0);
  EXPECT_THROW(slam->addScan(nowhere, truthAt(0)), ScanRefused);
  // What one sensor varies by goes on: a beam less, the aperture's centre a quarter of a beam on
  // (an interlacing scanner), 2 mm of mounting. The first such scan settles the setup: later
  // scans are not checked again (a converter may interpolate the laser pose scan by scan).
  RangeScan interlaced = same;
  interlaced.ranges.pop_back();
  interlaced.angle_min += 0.25 * interlaced.angle_increment;
  interlaced.laser_in_robot = core::Pose2(0.002, 0.0, 0.0);
  interlaced.timestamp = 1000.0;
  EXPECT_NO_THROW(slam->addScan(interlaced, truthAt(0)));
  RangeScan later = same;
  later.laser_in_robot = core::Pose2(0.02, 0.0, 0.0);
  later.timestamp = 1000.1;
  EXPECT_NO_THROW(slam->addScan(later, truthAt(1)));
}

TEST(SensorSetup, ComparesWhatMakesOneSensorAnother) {
  RangeScan sick;  // 181 beams over 180 degrees, looking ahead
  sick.angle_min = -M_PI / 2;
  sick.angle_increment = M_PI / 180;
  sick.ranges.assign(181, 1.0F);
  RangeScan turned = sick;  // the same laser mounted at a right angle
  turned.laser_in_robot = core::Pose2(0.0, 0.0, M_PI / 2);
  EXPECT_FALSE(SensorSetup::of(turned).sameAs(SensorSetup::of(sick)));
  RangeScan wrapped = sick;  // ... looking back, its centre across +-pi
  wrapped.laser_in_robot = core::Pose2(0.0, 0.0, M_PI - 0.001);
  RangeScan wrapped_other = sick;
  wrapped_other.laser_in_robot = core::Pose2(0.0, 0.0, -M_PI + 0.001);
  EXPECT_TRUE(SensorSetup::of(wrapped).sameAs(SensorSetup::of(wrapped_other)));
  EXPECT_FALSE(SensorSetup::of(wrapped).sameAs(SensorSetup::of(sick)));
  // A full circle counted from 0 or from -pi is the same sensor.
  RangeScan ring;
  ring.angle_min = -M_PI;
  ring.angle_increment = 2 * M_PI / 360;
  ring.ranges.assign(360, 1.0F);
  RangeScan from_zero = ring;
  from_zero.angle_min = 0.0;
  EXPECT_TRUE(SensorSetup::of(from_zero).sameAs(SensorSetup::of(ring)));
  // Symmetric: the finer and the coarser scan disagree both ways.
  RangeScan coarse = sick;
  coarse.angle_increment *= 1.02;
  coarse.ranges.resize(177);
  EXPECT_EQ(SensorSetup::of(coarse).sameAs(SensorSetup::of(sick)),
            SensorSetup::of(sick).sameAs(SensorSetup::of(coarse)));
  EXPECT_FALSE(SensorSetup::of(coarse).sameAs(SensorSetup::of(sick)));
}

TEST(MapFile, ANewSessionInAnotherOdometryFrameIsTiedToTheMap) {
  const MapSnapshot map = readMapFile(savedMap());
  auto slam = LaserSlam::fromMap(map, smallMaps(), "second");
  // The second run's odometry starts somewhere else entirely.
  const core::Pose2 elsewhere(100.0, -50.0, 2.0);
  drive(*slam, elsewhere, 100, 1000.0);
  ASSERT_TRUE(slam->tie().has_value()) << "the session never joined the map";
  // Placed by the first matches, confirmed by those 3 m on (one node per 0.09 m scan here).
  EXPECT_LT(slam->tie()->node - static_cast<int>(map.nodes.size()), 75);
  slam->finish();
  // Tied, the second session's nodes sit where the robot was, in the first session's frame
  // (which is the room's: its first odometry pose was the truth).
  const auto poses = slam->rrr().mapPoses();
  const auto& stamps = slam->nodeTimestamps();
  for (std::size_t k = map.nodes.size(); k < poses.size(); ++k) {
    const int scan = static_cast<int>(std::lround((stamps[k] - 1000.0) / 0.1));
    EXPECT_LT((poses[k].head<2>() - truthAt(scan).head<2>()).norm(), 0.1) << "node " << k;
  }
  ASSERT_EQ(slam->sessions().size(), 2u);
  EXPECT_EQ(slam->sessions()[1].first_node, static_cast<int>(map.nodes.size()));
  const MapSnapshot both = slam->snapshot();
  EXPECT_EQ(both.sessions.size(), 2u);
  EXPECT_EQ(both.nodes.back().session, 1);
  // The map's own loops keep their source; the session was tied by the whole-map search, then
  // searched around its estimate; a loop from outside the search is recorded as such.
  std::map<LoopSource, int> to_map, loaded;
  for (const MapSnapshot::Edge& e : map.edges) {
    if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate) ++loaded[e.source];
  }
  std::map<LoopSource, int> old_loops;
  const int first = static_cast<int>(map.nodes.size());
  for (const MapSnapshot::Edge& e : both.edges) {
    if (e.kind != MapSnapshot::EdgeKind::kLoopCandidate) continue;
    if (std::max(e.from, e.to) < first) {
      ++old_loops[e.source];
    } else if (std::min(e.from, e.to) < first) {
      ++to_map[e.source];
    }
  }
  EXPECT_EQ(old_loops, loaded);
  EXPECT_GT(to_map[LoopSource::kWholeMapSearch], 0);
  EXPECT_GT(to_map[LoopSource::kLocalSearch], 0);
  EXPECT_EQ(to_map[LoopSource::kUnknown], 0);
  const int newest = static_cast<int>(both.nodes.size()) - 1;
  ASSERT_TRUE(slam->addCandidate(newest - 60, newest, core::Pose2(0.5, 0.0, 0.0),
                                 Eigen::Matrix3d::Identity()));
  const MapSnapshot more = slam->snapshot();
  EXPECT_EQ(toString(more.edges.back().source), "external");

  // RRR numbers candidates by their newest end once a map is loaded again, not by arrival: one
  // given late between two early nodes moves ahead of the session's loops. Another taken by RRR
  // directly (as the ROS node's loop_candidates topic does in scan mode) is external too.
  ASSERT_TRUE(slam->addCandidate(10, 40, core::Pose2(3.0, 0.0, 0.0), Eigen::Matrix3d::Identity(),
                                 LoopSource::kInjected));
  slam->rrr().addCandidate(5, static_cast<rrr::OnlineRrr::NodeId>(newest),
                           core::Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  slam->finish();
  const MapSnapshot mixed = slam->snapshot();
  EXPECT_EQ(mixed.edges.back().source, LoopSource::kExternal);
  const std::string path = tempPath("mixed_sources.rrrmap");
  writeMapFile(mixed, path);
  const MapSnapshot again = LaserSlam::fromMap(readMapFile(path), smallMaps(), "third")->snapshot();
  using Loop = std::tuple<int, int, LoopSource>;
  auto loops = [](const MapSnapshot& m) {
    std::vector<Loop> out;
    for (const MapSnapshot::Edge& e : m.edges) {
      if (e.kind == MapSnapshot::EdgeKind::kLoopCandidate) out.emplace_back(e.from, e.to, e.source);
    }
    return out;
  };
  const std::vector<Loop> before = loops(mixed), after = loops(again);
  EXPECT_NE(before, after) << "the late candidate was expected to move ahead";
  EXPECT_EQ(std::multiset<Loop>(before.begin(), before.end()),
            std::multiset<Loop>(after.begin(), after.end()));
}

TEST(MapFile, LoopsAtOnePlaceWaitUntilLoopsFarEnoughApartTieTheSession) {
  // RRR ties a session only through agreeing loops seen relocalization_confirm_distance apart
  // along it (rrr/session_placement.h): before, they wait, pending, and the whole map is searched.
  const MapSnapshot map = readMapFile(savedMap());
  LaserSlamParams params = smallMaps();
  params.loops.relocalization_confirm_distance_m = 50.0;  // farther than this run goes
  auto slam = LaserSlam::fromMap(map, params, "second");
  const core::Pose2 elsewhere(100.0, -50.0, 2.0);
  drive(*slam, elsewhere, 60, 1000.0);
  EXPECT_FALSE(slam->placed());
  EXPECT_FALSE(slam->tied());
  EXPECT_FALSE(slam->tie().has_value());
  const rrr::OnlineRrr& rrr = slam->rrr();
  const int first = static_cast<int>(map.nodes.size());
  int waiting = 0;
  for (int c = 0; c < rrr.numCandidates(); ++c) {
    const auto& link = rrr.candidate(c);
    if (std::min(link.from, link.to) >= first || std::max(link.from, link.to) < first) continue;
    if (rrr.verdict(c) != rrr::Verdict::kPending || rrr.reason(c).rfind("placement:", 0) != 0) {
      continue;
    }
    ++waiting;
  }
  EXPECT_GT(waiting, 0) << "no loop to the map waits for its session to be placed";
  const long long whole = slam->stats().relocalization_searches;
  drive(*slam, elsewhere, 40, 1000.0, 60);
  EXPECT_GT(slam->stats().relocalization_searches, whole);
  slam->finish();  // never placed: its loops to the map end rejected, saying why
  for (int c = 0; c < rrr.numCandidates(); ++c) {
    const auto& link = rrr.candidate(c);
    if (std::min(link.from, link.to) >= first || std::max(link.from, link.to) < first) continue;
    EXPECT_EQ(rrr.verdict(c), rrr::Verdict::kRejected) << "candidate " << c;
  }
  // With a distance of the room's scale, the same run ties.
  auto tied = LaserSlam::fromMap(map, smallMaps(), "third");
  drive(*tied, elsewhere, 100, 1000.0);
  EXPECT_TRUE(tied->tied());
  EXPECT_GE(tied->acceptedCrossingSpread(), 3.0);
}

TEST(MapFile, APartOfTheMapThatNeverTiedIsJoinedByALaterSession) {
  const MapSnapshot map = readMapFile(savedMap());
  // The second session, told it starts 40 m away from the map, finds no loop to it: the map keeps
  // it as a part of its own, in its own odometry frame.
  auto second = LaserSlam::fromMap(map, smallMaps(), "second");
  second->setInitialPose(core::Pose2(40.0, 0.0, 0.0));
  drive(*second, core::Pose2(100.0, -50.0, 2.0), 60, 1000.0);
  second->finish();
  ASSERT_FALSE(second->tied());
  const MapSnapshot two = second->snapshot();
  // The third is told where it starts, so until it is tied it searches the first session's
  // submaps around there only; tied, it goes on searching the part it is not joined to, whole.
  auto third = LaserSlam::fromMap(two, smallMaps(), "third");
  third->setInitialPose(truthAt(0));
  drive(*third, core::Pose2(-40.0, 30.0, -1.0), 120, 2000.0);
  ASSERT_TRUE(third->tied());
  EXPECT_GT(third->stats().relocalization_searches, 0);
  third->finish();
  // The second session's nodes now lie where the robot was, in the room's frame.
  const auto poses = third->rrr().mapPoses();
  const auto& stamps = third->nodeTimestamps();
  const auto first = static_cast<std::size_t>(two.sessions[1].first_node);
  ASSERT_LT(first, two.nodes.size());
  for (std::size_t k = first; k < two.nodes.size(); ++k) {
    const int scan = static_cast<int>(std::lround((stamps[k] - 1000.0) / 0.1));
    EXPECT_LT((poses[k].head<2>() - truthAt(scan).head<2>()).norm(), 0.1) << "node " << k;
  }
}

TEST(MapFile, LocalizationTracksTheRobotAndLeavesTheMapAsItIs) {
  const MapSnapshot map = readMapFile(savedMap());
  auto slam = LaserSlam::fromMap(map, smallMaps(), "localize", SessionMode::kLocalization);
  const core::Pose2 elsewhere(100.0, -50.0, 2.0);
  drive(*slam, elsewhere, 100, 1000.0);
  slam->finish();
  ASSERT_TRUE(slam->tie().has_value()) << "never localized";
  const auto poses = slam->rrr().mapPoses();
  const auto n = map.nodes.size();
  for (std::size_t k = 0; k < n; ++k) {
    EXPECT_LT((poses[k] - map.nodes[k].map_pose).norm(), 1e-9) << "map node " << k << " moved";
  }
  const auto& stamps = slam->nodeTimestamps();
  for (std::size_t k = static_cast<std::size_t>(slam->tie()->node); k < poses.size(); ++k) {
    const int scan = static_cast<int>(std::lround((stamps[k] - 1000.0) / 0.1));
    EXPECT_LT((poses[k].head<2>() - truthAt(scan).head<2>()).norm(), 0.1) << "node " << k;
  }
  // Nothing of the run joins the map: no submap to search, no scan to render, nothing to save.
  EXPECT_EQ(slam->mapInputs().scans.size(), n);
  EXPECT_EQ(slam->stats().finished_submaps, static_cast<int>(map.submaps.size()));
  EXPECT_THROW(slam->snapshot(), std::logic_error);
  // The map's own loops are not decided again: only the run's loops to the map are candidates.
  for (int k = 0; k < slam->rrr().numCandidates(); ++k) {
    EXPECT_GE(std::max(slam->rrr().candidate(k).from, slam->rrr().candidate(k).to),
              static_cast<int>(n));
  }
}

// A map big enough that writing it takes a while: thousands of long scans of random ranges
// (which zlib cannot shrink much).
MapSnapshot bigMap(int nodes, float range) {
  MapSnapshot map;
  map.sessions.push_back({"big", 0.0, 0});
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> ranges(0.1F, range);
  for (int k = 0; k < nodes; ++k) {
    auto scan = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
    scan->resizeScan(1081);
    for (std::size_t i = 0; i < 1081; ++i) scan->setScanRange(i, ranges(rng));
    map.nodes.push_back({0, 0.1 * k, core::Pose2(0.1 * k, 0, 0), core::Pose2(0.1 * k, 0, 0), scan});
    if (k > 0) {
      map.edges.push_back({k - 1, k, MapSnapshot::EdgeKind::kOdometry, core::Pose2(0.1, 0, 0),
                           Eigen::Matrix3d::Identity(), rrr::Verdict::kPending, -1, ""});
    }
  }
  map.submaps.push_back({0, nodes - 1});
  return map;
}

// A temporary file of `path` being written (path.tmp.XXXXXX), if there is one.
std::string temporaryOf(const std::string& path) {
  const std::string dir = path.substr(0, path.rfind('/'));
  const std::string prefix = path.substr(path.rfind('/') + 1) + ".tmp.";
  std::string found;
  if (DIR* d = opendir(dir.c_str())) {
    while (const dirent* e = readdir(d)) {
      if (std::string(e->d_name).rfind(prefix, 0) == 0) found = dir + "/" + e->d_name;
    }
    closedir(d);
  }
  return found;
}

TEST(MapFile, AProcessKilledWhileSavingLeavesThePreviousMapWhole) {
  const std::string path = tempPath("killed.rrrmap");
  writeMapFile(bigMap(10, 1.0F), path);  // the previous map
  const MapSnapshot next = bigMap(2000, 2.0F);
  int killed_while_writing = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      writeMapFile(next, path);
      _exit(0);
    }
    // Killed the moment its temporary file appears: in the middle of writing the new map.
    std::string temporary;
    for (int k = 0; k < 200000 && temporary.empty(); ++k) {
      temporary = temporaryOf(path);
      if (temporary.empty()) std::this_thread::sleep_for(std::chrono::microseconds(20));
    }
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    const MapSnapshot read = readMapFile(path);
    if (!temporaryOf(path).empty()) {
      ++killed_while_writing;
      EXPECT_EQ(read.nodes.size(), 10u) << "a save killed mid-write replaced the map";
      std::remove(temporaryOf(path).c_str());
    } else {
      // It got as far as the rename: the new map, whole.
      EXPECT_EQ(read.nodes.size(), 2000u);
      writeMapFile(bigMap(10, 1.0F), path);
    }
  }
  EXPECT_GT(killed_while_writing, 0) << "no kill landed while the file was written";
}

TEST(MapFile, AnInitialPoseRestrictsTheSearchAroundIt) {
  const MapSnapshot map = readMapFile(savedMap());
  const core::Pose2 elsewhere(100.0, -50.0, 2.0);
  // Right: the first node is where the robot truly is; no submap is searched whole.
  auto hinted = LaserSlam::fromMap(map, smallMaps(), "hinted");
  hinted->setInitialPose(truthAt(0));
  drive(*hinted, elsewhere, 100, 1000.0);
  EXPECT_TRUE(hinted->tie().has_value());
  EXPECT_EQ(hinted->stats().relocalization_searches, 0);
  // Wrong by 40 m: nothing near it in the map, so nothing is found, not even far away.
  auto misled = LaserSlam::fromMap(map, smallMaps(), "misled");
  misled->setInitialPose(core::Pose2(40.0, 0.0, 0.0));
  drive(*misled, elsewhere, 100, 1000.0);
  EXPECT_FALSE(misled->tie().has_value());
  EXPECT_EQ(misled->stats().relocalization_searches, 0);
  // In a first session there is no map to be placed in.
  LaserSlam fresh(smallMaps());
  EXPECT_THROW(fresh.setInitialPose(core::Pose2::Zero()), std::logic_error);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
