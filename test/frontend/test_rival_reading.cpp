// Rival readings (rival_reading.h): the grid-hashed grouping against the obvious all-pairs one, and
// LaserSlam searching a second reading of where a tied session lies once enough of its
// unaccepted loops to the map agree on it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/map_file.h"
#include "rrr_graphslam/frontend/rival_reading.h"
#include "synthetic_room.h"

namespace rrr_graphslam::frontend {
namespace {

// The obvious version: every pair compared.
std::optional<core::Pose2> largestReadingSlow(const std::vector<SessionReading>& readings,
                                              std::size_t min_size,
                                              const ReadingAgreement& within) {
  std::size_t best = 0;
  std::size_t best_count = 0;
  for (std::size_t k = 0; k < readings.size(); ++k) {
    std::size_t count = 0;
    for (const SessionReading& r : readings) {
      count += readingsAgree(r.pose, readings[k].pose, within) ? 1 : 0;
    }
    if (count > best_count) {
      best = k;
      best_count = count;
    }
  }
  if (best_count == 0 || best_count < min_size) return std::nullopt;
  std::size_t newest = best;
  for (std::size_t j = 0; j < readings.size(); ++j) {  // by index: the first among equals
    if (readingsAgree(readings[j].pose, readings[best].pose, within) &&
        readings[j].session_node > readings[newest].session_node) {
      newest = j;
    }
  }
  for (std::size_t j = 0; j < newest; ++j) {
    if (readingsAgree(readings[j].pose, readings[best].pose, within) &&
        readings[j].session_node == readings[newest].session_node) {
      return readings[j].pose;
    }
  }
  return readings[newest].pose;
}

TEST(RivalReading, GridGroupingEqualsTheAllPairsOne) {
  const ReadingAgreement within;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int found = 0;
  for (int trial = 0; trial < 300; ++trial) {
    // A few groups (some straddling grid lines and the angle's wrap), scattered single readings.
    std::vector<SessionReading> readings;
    const int groups = 1 + trial % 4;
    for (int g = 0; g < groups; ++g) {
      const core::Pose2 centre(std::round(8.0 * uniform(rng)) * within.distance_m,
                               std::round(8.0 * uniform(rng)) * within.distance_m,
                               g % 2 == 0 ? M_PI - 0.05 : 3.0 * uniform(rng));
      const int size = 1 + static_cast<int>(std::abs(uniform(rng)) * 9);
      for (int k = 0; k < size; ++k) {
        readings.push_back(
            {core::Pose2(centre.x() + 1.5 * uniform(rng), centre.y() + 1.5 * uniform(rng),
                         core::normalizeAngle(centre.z() + 0.15 * uniform(rng))),
             static_cast<int>(readings.size() * 7 % 23)});
      }
    }
    for (int k = 0; k < trial % 10; ++k) {
      readings.push_back(
          {core::Pose2(40.0 * uniform(rng), 40.0 * uniform(rng), 3.0 * uniform(rng)), 100 + k});
    }
    for (std::size_t min_size : {std::size_t{1}, std::size_t{3}, std::size_t{6}}) {
      const auto fast = largestReading(readings, min_size, within);
      const auto slow = largestReadingSlow(readings, min_size, within);
      ASSERT_EQ(fast.has_value(), slow.has_value()) << "trial " << trial << " min " << min_size;
      if (!fast) continue;
      ++found;
      EXPECT_EQ(fast->pose, *slow) << "trial " << trial << " min " << min_size;
    }
  }
  EXPECT_GT(found, 300);
}

TEST(RivalReading, AgreementWrapsTheAngleAndNeedsEnoughReadings) {
  const ReadingAgreement within;
  EXPECT_TRUE(readingsAgree({0, 0, M_PI - 0.05}, {1.0, 1.0, -M_PI + 0.05}, within));
  EXPECT_FALSE(readingsAgree({0, 0, 0}, {2.1, 0, 0}, within));
  EXPECT_FALSE(readingsAgree({0, 0, 0}, {0, 0, 0.25}, within));
  std::vector<SessionReading> readings = {
      {{5, 5, 3.1}, 10}, {{5.5, 5, -3.1}, 30}, {{5, 5.5, 3.0}, 20}};
  EXPECT_FALSE(largestReading(readings, 4).has_value());
  const auto three = largestReading(readings, 3);
  ASSERT_TRUE(three.has_value());
  EXPECT_EQ(three->pose, readings[1].pose) << "the newest of the group";
  EXPECT_EQ(three->size, 3u);
  EXPECT_FALSE(largestReading({}, 0).has_value());
}

using testing::drive;

LaserSlamParams roomParams(int rival_min_loops) {
  LaserSlamParams p = testing::roomSizedParams();
  p.loops.relocalization_confirm_distance_m = 3.0;
  p.loops.rival_min_loops = rival_min_loops;
  return p;
}

const MapSnapshot& roomMap() {
  static const MapSnapshot map = [] {
    LaserSlam slam(roomParams(0), "first");
    drive(slam, core::Pose2::Zero(), 130, 0.0);
    slam.finish();
    return slam.snapshot();
  }();
  return map;
}

// `count` loops from the map's nodes to the session's newest nodes (from the `first`-th on), each
// putting the session where `motion` (map frame) moves it from where the map has it now: one
// other reading.
void addOtherReading(LaserSlam& slam, const core::Pose2& motion, int first, int count,
                     int map_nodes) {
  const auto poses = slam.rrr().mapPoses();
  const int newest = static_cast<int>(poses.size()) - 1;
  for (int k = first; k < first + count; ++k) {
    const int map_node = 5 + (7 * k) % (map_nodes - 10);
    const int session_node = newest - k % 40;
    const core::Pose2 elsewhere =
        core::compose(motion, poses[static_cast<std::size_t>(session_node)]);
    ASSERT_TRUE(slam.addCandidate(
        map_node, session_node, core::between(poses[static_cast<std::size_t>(map_node)], elsewhere),
        Eigen::Vector3d(400, 400, 1600).asDiagonal().toDenseMatrix(), LoopSource::kInjected));
  }
}

// Loops RRR accepts between the session and the map.
int tiedLoops(const LaserSlam& slam, int map_nodes) {
  int tied = 0;
  for (int c = 0; c < slam.rrr().numCandidates(); ++c) {
    const auto& link = slam.rrr().candidate(c);
    const bool crossing =
        std::min(link.from, link.to) < map_nodes && std::max(link.from, link.to) >= map_nodes;
    tied += crossing && slam.rrr().verdict(c) == rrr::Verdict::kAccepted ? 1 : 0;
  }
  return tied;
}

TEST(RivalReading, ATiedSessionSearchesTheReadingEnoughUnacceptedLoopsAgreeOn) {
  const core::Pose2 elsewhere(100.0, -50.0, 2.0);
  const core::Pose2 turned(12.0, 8.0, M_PI);  // the room read from its other end
  const int map_nodes = static_cast<int>(roomMap().nodes.size());
  auto slam = LaserSlam::fromMap(roomMap(), roomParams(5), "second");
  drive(*slam, elsewhere, 100, 1000.0);
  ASSERT_TRUE(slam->tied());
  EXPECT_EQ(slam->stats().rival_searches, 0)
      << "the session's own unaccepted loops were not expected to agree";
  // Enough loops: rival_min_loops, and a quarter of the tied reading's.
  const int tied = tiedLoops(*slam, map_nodes);
  const int needed = std::max(5, (tied + 3) / 4);
  ASSERT_GT(needed, 5) << "the tie was expected to hold more than 20 loops (" << tied << ")";
  addOtherReading(*slam, turned, 0, 4, map_nodes);
  drive(*slam, elsewhere, 10, 1000.0, 100);
  EXPECT_EQ(slam->stats().rival_searches, 0) << "four loops are fewer than rival_min_loops";
  addOtherReading(*slam, turned, 4, needed - 5, map_nodes);
  drive(*slam, elsewhere, 10, 1000.0, 110);
  EXPECT_EQ(slam->stats().rival_searches, 0)
      << needed - 1 << " loops are fewer than a quarter of the tied reading's " << tied;
  addOtherReading(*slam, turned, needed - 1, needed, map_nodes);
  drive(*slam, elsewhere, 10, 1000.0, 120);
  EXPECT_GT(slam->stats().rival_searches, 0) << "tied loops " << tiedLoops(*slam, map_nodes);
  EXPECT_TRUE(slam->tied()) << "the tie stays with the reading its loops agree on";

  auto off = LaserSlam::fromMap(roomMap(), roomParams(0), "second");
  drive(*off, elsewhere, 100, 1000.0);
  ASSERT_TRUE(off->tied());
  addOtherReading(*off, turned, 0, 2 * needed, map_nodes);
  drive(*off, elsewhere, 20, 1000.0, 100);
  EXPECT_EQ(off->stats().rival_searches, 0);
}

}  // namespace
}  // namespace rrr_graphslam::frontend
