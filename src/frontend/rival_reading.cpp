#include "rrr_graphslam/frontend/rival_reading.h"

#include <cmath>
#include <map>
#include <utility>

namespace rrr_graphslam::frontend {

bool readingsAgree(const core::Pose2& a, const core::Pose2& b, const ReadingAgreement& within) {
  return (a.head<2>() - b.head<2>()).norm() <= within.distance_m &&
         std::abs(core::normalizeAngle(a.z() - b.z())) <= within.angle_rad;
}

std::optional<ReadingGroup> largestReading(const std::vector<SessionReading>& readings,
                                           std::size_t min_size, const ReadingAgreement& within) {
  if (readings.empty() || readings.size() < min_size) return std::nullopt;
  // Readings by grid cell: those agreeing with one lie in its 3 x 3 cells.
  using Cell = std::pair<long long, long long>;
  const auto cell_of = [&](const core::Pose2& p) {
    return Cell{static_cast<long long>(std::floor(p.x() / within.distance_m)),
                static_cast<long long>(std::floor(p.y() / within.distance_m))};
  };
  std::map<Cell, std::vector<std::size_t>> cells;
  for (std::size_t k = 0; k < readings.size(); ++k) {
    cells[cell_of(readings[k].pose)].push_back(k);
  }
  const auto agreeing = [&](std::size_t k) {
    std::vector<std::size_t> out;
    const Cell c = cell_of(readings[k].pose);
    for (long long dx = -1; dx <= 1; ++dx) {
      for (long long dy = -1; dy <= 1; ++dy) {
        const auto it = cells.find({c.first + dx, c.second + dy});
        if (it == cells.end()) continue;
        for (std::size_t j : it->second) {
          if (readingsAgree(readings[j].pose, readings[k].pose, within)) out.push_back(j);
        }
      }
    }
    return out;
  };
  std::size_t best = 0;
  std::size_t best_count = 0;
  for (std::size_t k = 0; k < readings.size(); ++k) {
    const std::size_t count = agreeing(k).size();
    if (count > best_count) {
      best = k;
      best_count = count;
    }
  }
  if (best_count < min_size) return std::nullopt;
  std::size_t newest = best;
  for (std::size_t j : agreeing(best)) {  // among equals the first, as the grid's order is not
    const int a = readings[j].session_node, b = readings[newest].session_node;
    if (a > b || (a == b && j < newest)) newest = j;
  }
  return ReadingGroup{readings[newest].pose, best_count};
}

}  // namespace rrr_graphslam::frontend
