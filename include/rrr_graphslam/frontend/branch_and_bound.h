#pragma once
// Branch-and-bound scan-to-submap matching (Hess et al., ICRA 2016, Algorithms 2-3; the bounds of
// Olson, ICRA 2009): the best pose of a scan in a search window, exactly as an exhaustive search
// over the same discretization would find it (matchExhaustive is that slow obvious version; the
// tests compare them), without scoring most of the window.
//
// Discretization: translations on the grid's cells, rotations in steps so that the farthest point
// moves by at most one cell. Score: the mean over the points of the (quantized) probability of the
// cell they fall in; a match must score above min_score.

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/frontend/precomputation_grid.h"

namespace rrr_graphslam::frontend {

using PointCloud = std::vector<Eigen::Vector2d>;

struct SearchWindow {
  double linear_m = 7.0;                   ///< half-width of the square of translations
  double angular_rad = 30.0 * M_PI / 180;  ///< half-width of the rotations
};

struct ScanMatch {
  core::Pose2 pose;  ///< the scan's pose in the submap frame
  double score;      ///< in [0, 1]
};

/// Poses a search leaves out: those within linear_m of `center`'s position and within angular_rad
/// of its heading (the place a match found before, when the search looks for another place the
/// scan fits).
struct Exclusion {
  core::Pose2 center;
  double linear_m;
  double angular_rad;
};

class FastCorrelativeScanMatcher {
 public:
  /// Precomputes `depth` levels of max-grids (level depth-1 is the coarsest).
  FastCorrelativeScanMatcher(const MatchGrid& grid, int depth);

  /// The best pose within `window` around `initial` (submap frame) scoring above `min_score`,
  /// outside `exclude` when given. `scored`, when given, receives the number of candidates the
  /// search scored (all levels). The matcher is const and keeps no state of a search: loop search
  /// threads may match against one submap at once.
  std::optional<ScanMatch> match(const core::Pose2& initial, const PointCloud& points,
                                 const SearchWindow& window, double min_score,
                                 const std::optional<Exclusion>& exclude = std::nullopt,
                                 long long* scored = nullptr) const;
  /// Relocalization: every translation that keeps the scan's origin on the submap, every rotation.
  std::optional<ScanMatch> matchFullSubmap(
      const PointCloud& points, double min_score,
      const std::optional<Exclusion>& exclude = std::nullopt) const;
  /// The same result by scoring every discrete pose of the window (for tests and benchmarks).
  std::optional<ScanMatch> matchExhaustive(const core::Pose2& initial, const PointCloud& points,
                                           const SearchWindow& window, double min_score,
                                           const std::optional<Exclusion>& exclude = std::nullopt,
                                           long long* scored = nullptr) const;

  const PrecomputationGridStack& grids() const { return grids_; }
  /// Cell size of the grid it searches.
  double resolution() const { return grids_.resolution(); }

 private:
  struct DiscreteScan {
    double angle;                       ///< absolute rotation of the scan
    std::vector<Eigen::Array2i> cells;  ///< points at the initial translation, as cells
    bool excluded_heading = false;      ///< within the exclusion's angular_rad
  };
  struct Candidate {
    int scan;
    int x;
    int y;
    int score;  ///< sum of quantized values
  };
  struct Discretization {
    std::vector<DiscreteScan> scans;
    int window_cells;
    bool excluding = false;
    Eigen::Vector2d excluded_center;  ///< in cells from the initial translation
    double excluded_radius = 0.0;     ///< in cells
    /// Whether every translation of the size x size block of cells at (x, y) of `scan` is
    /// excluded (a block of 1: one pose).
    bool excluded(int scan, int x, int y, int size) const;
  };

  Discretization discretize(const core::Pose2& initial, const PointCloud& points,
                            const SearchWindow& window,
                            const std::optional<Exclusion>& exclude) const;
  /// Sum of level `level` over the scan's cells shifted by (x, y). Stops as soon as the sum can
  /// no longer exceed `floor` (each cell left adds at most 255) and returns that bound, which is
  /// then <= floor: a candidate below the best so far is discarded without reading every cell.
  int score(const DiscreteScan& scan, int level, int x, int y, int floor) const;
  /// Branch and bound below `level`; adds the candidates it scores to `scored`.
  std::optional<Candidate> search(const Discretization& d, std::vector<Candidate>& candidates,
                                  int level, int min_score, long long& scored) const;
  ScanMatch toMatch(const core::Pose2& initial, const Discretization& d, const Candidate& c,
                    std::size_t num_points) const;

  PrecomputationGridStack grids_;
  Eigen::Vector2d grid_center_;
  double grid_radius_;
};

}  // namespace rrr_graphslam::frontend
