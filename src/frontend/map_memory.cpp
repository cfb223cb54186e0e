#include "rrr_graphslam/frontend/map_memory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rrr_graphslam::frontend {

void RememberedCells::check(int nodes) const {
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (session < 0) fail("its session " + std::to_string(session) + " is negative");
  if (anchor_node < 0 || anchor_node >= nodes) {
    fail("its anchor node " + std::to_string(anchor_node) + " is not one of the map's " +
         std::to_string(nodes) + " nodes");
  }
  if (!origin.allFinite()) fail("its origin is not finite");
  if (!(resolution_m >= 1e-3 && resolution_m <= 10.0)) {
    fail("its resolution " + std::to_string(resolution_m) + " m is not in [0.001, 10]");
  }
  if (width <= 0 || height <= 0 ||
      static_cast<double>(width) * static_cast<double>(height) > kMaxCells) {
    fail("its size " + std::to_string(width) + " x " + std::to_string(height) +
         " cells is not positive or above " + std::to_string(kMaxCells));
  }
  const std::size_t expected = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (!cells || cells->size() != expected) {
    fail("it holds " + std::to_string(cells ? cells->size() : 0) + " cells, not " +
         std::to_string(width) + " x " + std::to_string(height));
  }
}

std::size_t RememberedCells::knownCells() const {
  if (!cells) return 0;
  return static_cast<std::size_t>(
      std::count_if(cells->begin(), cells->end(), [](std::uint8_t v) { return v != kUnknown; }));
}

namespace {
// map_server's default thresholds (map_io.h's MapServerThresholds) on the probability of being
// free: occupied at or below, free at or above.
constexpr float kOccupiedFree = 0.35F;
constexpr float kFreeFree = 0.804F;
}  // namespace

std::uint8_t rememberedValue(float free_probability) {
  const float p = std::clamp(free_probability, 0.0F, 1.0F);
  const auto v = static_cast<int>(1 + std::lround(254.0F * p));
  if (p <= kOccupiedFree)
    return static_cast<std::uint8_t>(std::min<int>(v, RememberedCells::kLastOccupied));
  if (p >= kFreeFree)
    return static_cast<std::uint8_t>(std::max<int>(v, RememberedCells::kFirstFree));
  return static_cast<std::uint8_t>(
      std::clamp<int>(v, RememberedCells::kLastOccupied + 1, RememberedCells::kFirstFree - 1));
}

float freeProbability(std::uint8_t value) {
  return static_cast<float>(std::max<int>(value, 1) - 1) / 254.0F;
}

bool isDecision(std::uint8_t value) {
  return value != RememberedCells::kUnknown &&
         (value <= RememberedCells::kLastOccupied || value >= RememberedCells::kFirstFree);
}

float occupancyLogOdds(float free_probability) {
  const float p = std::clamp(free_probability, 1e-3F, 1.0F - 1e-3F);
  return std::log((1.0F - p) / p);
}

float evidenceLogOdds(std::uint8_t value) { return occupancyLogOdds(freeProbability(value)); }

float freeProbabilityOfLogOdds(float log_odds) { return 1.0F / (1.0F + std::exp(log_odds)); }

core::Pose2 patchPose(const RememberedCells& patch, const core::Pose2& anchor_map_pose) {
  return core::compose(anchor_map_pose, patch.origin);
}

RememberedCells reanchored(const RememberedCells& patch, const core::Pose2& anchor_map_pose,
                           int new_anchor, const core::Pose2& new_anchor_map_pose) {
  RememberedCells out = patch;
  out.anchor_node = new_anchor;
  out.origin = core::between(new_anchor_map_pose, patchPose(patch, anchor_map_pose));
  return out;
}

std::size_t rememberedCells(const std::vector<RememberedCells>& memory) {
  std::size_t n = 0;
  for (const RememberedCells& patch : memory) n += patch.knownCells();
  return n;
}

}  // namespace rrr_graphslam::frontend
