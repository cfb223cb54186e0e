#include "rrr_graphslam/frontend/branch_and_bound.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rrr_graphslam::frontend {
namespace {

// Sum of quantized values a match must exceed for a mean above min_score.
int minimumSum(double min_score, std::size_t num_points) {
  return static_cast<int>(
      std::floor(std::clamp(min_score, 0.0, 1.0) * 255.0 * static_cast<double>(num_points)));
}

}  // namespace

FastCorrelativeScanMatcher::FastCorrelativeScanMatcher(const MatchGrid& grid, int depth)
    : grids_(grid, depth),
      grid_center_(grid.origin() +
                   0.5 * grid.resolution() * Eigen::Vector2d(grid.width(), grid.height())),
      grid_radius_(0.5 * grid.resolution() * std::max(grid.width(), grid.height())) {}

bool FastCorrelativeScanMatcher::Discretization::excluded(int scan, int x, int y, int size) const {
  if (!excluding || !scans[static_cast<std::size_t>(scan)].excluded_heading) return false;
  // The disc is convex: the block is inside when its four corners are.
  const double r2 = excluded_radius * excluded_radius;
  for (const int cx : {x, x + size - 1}) {
    for (const int cy : {y, y + size - 1}) {
      if ((Eigen::Vector2d(cx, cy) - excluded_center).squaredNorm() > r2) return false;
    }
  }
  return true;
}

FastCorrelativeScanMatcher::Discretization FastCorrelativeScanMatcher::discretize(
    const core::Pose2& initial, const PointCloud& points, const SearchWindow& window,
    const std::optional<Exclusion>& exclude) const {
  if (!(window.linear_m >= 0.0) || !(window.angular_rad >= 0.0)) {
    throw std::invalid_argument("search window must be non-negative");
  }
  const double resolution = grids_.resolution();
  double max_range = resolution;
  for (const auto& p : points) max_range = std::max(max_range, p.norm());
  // The farthest point moves by at most one cell per angular step.
  const double angular_step =
      std::acos(1.0 - resolution * resolution / (2.0 * max_range * max_range));
  const int num_angles =
      static_cast<int>(std::ceil(std::min(window.angular_rad, M_PI) / angular_step));
  Discretization d;
  d.window_cells = static_cast<int>(std::ceil(window.linear_m / resolution));
  const Eigen::Vector2d t = initial.head<2>();
  for (int k = -num_angles; k <= num_angles; ++k) {
    DiscreteScan scan;
    scan.angle = initial.z() + k * angular_step;
    const Eigen::Matrix2d R = core::rotation(scan.angle);
    scan.cells.reserve(points.size());
    for (const auto& p : points) scan.cells.push_back(grids_.cellOf(t + R * p));
    scan.excluded_heading =
        exclude &&
        std::abs(core::normalizeAngle(scan.angle - exclude->center.z())) <= exclude->angular_rad;
    d.scans.push_back(std::move(scan));
  }
  if (exclude) {
    d.excluding = true;
    d.excluded_center = (exclude->center.head<2>() - t) / resolution;
    d.excluded_radius = exclude->linear_m / resolution;
  }
  return d;
}

int FastCorrelativeScanMatcher::score(const DiscreteScan& scan, int level, int x, int y,
                                      int floor) const {
  constexpr std::size_t kChunk = 16;  // cells summed between two checks against the floor
  const PrecomputationGrid& grid = grids_.level(level);
  const std::size_t n = scan.cells.size();
  int sum = 0;
  for (std::size_t i = 0; i < n;) {
    for (const std::size_t end = std::min(n, i + kChunk); i < end; ++i) {
      sum += grid.at(scan.cells[i].x() + x, scan.cells[i].y() + y);
    }
    const int bound = sum + 255 * static_cast<int>(n - i);
    if (bound <= floor) return bound;
  }
  return sum;
}

std::optional<FastCorrelativeScanMatcher::Candidate> FastCorrelativeScanMatcher::search(
    const Discretization& d, std::vector<Candidate>& candidates, int level, int min_score,
    long long& scored) const {
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  if (level == 0) {
    for (const Candidate& c : candidates) {
      if (c.score <= min_score) break;
      if (!d.excluded(c.scan, c.x, c.y, 1)) return c;
    }
    return std::nullopt;
  }
  std::optional<Candidate> best;
  const int half = 1 << (level - 1);
  for (const Candidate& c : candidates) {
    if (c.score <= min_score) break;  // sorted: no remaining candidate can beat the best
    if (d.excluded(c.scan, c.x, c.y, 1 << level)) continue;
    std::vector<Candidate> children;
    children.reserve(4);
    for (int dx = 0; dx <= half; dx += half) {
      if (c.x + dx > d.window_cells) break;
      for (int dy = 0; dy <= half; dy += half) {
        if (c.y + dy > d.window_cells) break;
        const DiscreteScan& scan = d.scans[static_cast<std::size_t>(c.scan)];
        children.push_back(
            {c.scan, c.x + dx, c.y + dy, score(scan, level - 1, c.x + dx, c.y + dy, min_score)});
        ++scored;
      }
    }
    if (auto found = search(d, children, level - 1, min_score, scored)) {
      best = found;
      min_score = found->score;
    }
  }
  return best;
}

ScanMatch FastCorrelativeScanMatcher::toMatch(const core::Pose2& initial, const Discretization& d,
                                              const Candidate& c, std::size_t num_points) const {
  const double resolution = grids_.resolution();
  return {core::Pose2(initial.x() + c.x * resolution, initial.y() + c.y * resolution,
                      core::normalizeAngle(d.scans[static_cast<std::size_t>(c.scan)].angle)),
          static_cast<double>(c.score) / (255.0 * static_cast<double>(num_points))};
}

std::optional<ScanMatch> FastCorrelativeScanMatcher::match(
    const core::Pose2& initial, const PointCloud& points, const SearchWindow& window,
    double min_score, const std::optional<Exclusion>& exclude, long long* scored) const {
  if (scored) *scored = 0;
  if (points.empty()) return std::nullopt;
  const Discretization d = discretize(initial, points, window, exclude);
  // The coarsest level's candidates tile the window; each stands for 2^h x 2^h translations.
  const int top = grids_.depth() - 1;
  const int step = 1 << top;
  const int floor = minimumSum(min_score, points.size());
  std::vector<Candidate> candidates;
  for (int s = 0; s < static_cast<int>(d.scans.size()); ++s) {
    for (int x = -d.window_cells; x <= d.window_cells; x += step) {
      for (int y = -d.window_cells; y <= d.window_cells; y += step) {
        const int sc = score(d.scans[static_cast<std::size_t>(s)], top, x, y, floor);
        if (sc > floor) candidates.push_back({s, x, y, sc});
      }
    }
  }
  long long count = static_cast<long long>(d.scans.size()) * ((2 * d.window_cells) / step + 1) *
                    ((2 * d.window_cells) / step + 1);
  const auto best = search(d, candidates, top, floor, count);
  if (scored) *scored = count;
  if (!best) return std::nullopt;
  return toMatch(initial, d, *best, points.size());
}

std::optional<ScanMatch> FastCorrelativeScanMatcher::matchFullSubmap(
    const PointCloud& points, double min_score, const std::optional<Exclusion>& exclude) const {
  const core::Pose2 center(grid_center_.x(), grid_center_.y(), 0.0);
  return match(center, points, SearchWindow{grid_radius_, M_PI}, min_score, exclude);
}

std::optional<ScanMatch> FastCorrelativeScanMatcher::matchExhaustive(
    const core::Pose2& initial, const PointCloud& points, const SearchWindow& window,
    double min_score, const std::optional<Exclusion>& exclude, long long* scored) const {
  if (scored) *scored = 0;
  if (points.empty()) return std::nullopt;
  const Discretization d = discretize(initial, points, window, exclude);
  std::optional<Candidate> best;
  int best_score = minimumSum(min_score, points.size());
  for (int s = 0; s < static_cast<int>(d.scans.size()); ++s) {
    for (int x = -d.window_cells; x <= d.window_cells; ++x) {
      for (int y = -d.window_cells; y <= d.window_cells; ++y) {
        if (d.excluded(s, x, y, 1)) continue;
        const int sc = score(d.scans[static_cast<std::size_t>(s)], 0, x, y, best_score);
        if (sc > best_score) {
          best_score = sc;
          best = Candidate{s, x, y, sc};
        }
      }
    }
  }
  if (scored) {
    *scored = static_cast<long long>(d.scans.size()) * (2 * d.window_cells + 1) *
              (2 * d.window_cells + 1);
  }
  if (!best) return std::nullopt;
  return toMatch(initial, d, *best, points.size());
}

}  // namespace rrr_graphslam::frontend
