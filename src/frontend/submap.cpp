#include "rrr_graphslam/frontend/submap.h"

#include <algorithm>
#include <stdexcept>

#include <mrpt/poses/CPose3D.h>

namespace rrr_graphslam::frontend {

void configureInsertion(mrpt::maps::COccupancyGridMap2D& grid, const SubmapParams& params) {
  auto& options = grid.insertionOptions;
  options.maxOccupancyUpdateCertainty = params.hit_probability;
  options.maxFreenessUpdateCertainty = 1.0F - params.miss_probability;
  options.maxDistanceInsertion = params.max_insertion_range_m;
  options.considerInvalidRangesAsFreeSpace = true;
  options.wideningBeamsWithDistance = false;
}

Submap::Submap(int index, int anchor_node, const core::Pose2& anchor_local_pose,
               const SubmapParams& params)
    : index_(index),
      anchor_node_(anchor_node),
      last_node_(anchor_node),
      anchor_pose_(anchor_local_pose),
      params_(params) {
  // Start small around the anchor; MRPT grows the grid to fit what is inserted.
  const auto x = static_cast<float>(anchor_local_pose.x());
  const auto y = static_cast<float>(anchor_local_pose.y());
  grid_ = std::make_unique<mrpt::maps::COccupancyGridMap2D>(
      x - 10.0F, x + 10.0F, y - 10.0F, y + 10.0F, static_cast<float>(params.resolution_m));
  configureInsertion(*grid_, params);
}

void Submap::insert(const mrpt::obs::CObservation2DRangeScan& scan, const core::Pose2& local_pose,
                    int node) {
  if (finished()) throw std::logic_error("Submap::insert: submap is finished");
  const mrpt::poses::CPose3D robot(local_pose.x(), local_pose.y(), 0.0, local_pose.z(), 0.0, 0.0);
  grid_->insertObservation(scan, robot);
  ++num_scans_;
  last_node_ = node;
  members_.push_back({node, local_pose});
  match_grid_dirty_ = true;
}

const MatchGrid& Submap::matchGrid() const {
  if (match_grid_dirty_ && grid_) {
    // Young while it holds fewer than young_submap_scans scans, and at most until the next submap
    // starts (half full): a submap of a few scans is young for half of them, not all.
    const int young = std::min(params_.young_submap_scans, params_.scans_per_submap / 2);
    const double unknown =
        num_scans_ < young ? params_.young_unknown_value : params_.active_unknown_value;
    match_grid_ = MatchGrid::fromOccupancyGrid(*grid_, static_cast<float>(unknown));
    match_grid_dirty_ = false;
  }
  return match_grid_;
}

void Submap::setYoungScans(int scans) {
  if (params_.young_submap_scans == scans) return;
  params_.young_submap_scans = scans;
  match_grid_dirty_ = !finished();
}

void Submap::finish() {
  if (finished()) return;
  // Frozen with the finished submap's score of never-observed cells (matchGrid() builds the
  // active one's).
  match_grid_ = MatchGrid::fromOccupancyGrid(*grid_, params_.unknown_value);
  match_grid_dirty_ = false;
  matcher_ = std::make_unique<FastCorrelativeScanMatcher>(
      match_grid_.maxPooled(params_.search_grid_factor), params_.branch_and_bound_depth);
  grid_.reset();
}

ActiveSubmaps::ActiveSubmaps(const SubmapParams& params, int first_index)
    : params_(params), first_index_(first_index), next_index_(first_index) {
  if (params.scans_per_submap < 2) throw std::invalid_argument("scans_per_submap must be >= 2");
  if (!(params.resolution_m > 0.0)) throw std::invalid_argument("resolution must be positive");
}

std::shared_ptr<Submap> ActiveSubmaps::insert(const mrpt::obs::CObservation2DRangeScan& scan,
                                              const core::Pose2& local_pose, int node) {
  if (start_next_) {
    start_next_ = false;
    active_.push_back(
        std::make_shared<Submap>(next_index_, node, local_pose, paramsOf(next_index_)));
    ++next_index_;
  }
  for (auto& submap : active_) submap->insert(scan, local_pose, node);
  std::shared_ptr<Submap> finished;
  if (active_.front()->numScans() >= params_.scans_per_submap) {
    finished = active_.front();
    finished->finish();
    active_.erase(active_.begin());
  }
  // The newer submap is half full: the next scan starts (and anchors) a new one.
  if (active_.empty() || active_.back()->numScans() == params_.scans_per_submap / 2) {
    start_next_ = true;
  }
  return finished;
}

std::vector<ActiveSubmaps::Contents> ActiveSubmaps::contents() const {
  std::vector<Contents> out;
  for (const auto& submap : active_) {
    out.push_back({submap->index(), submap->anchorPose(), submap->members()});
  }
  return out;
}

void ActiveSubmaps::rebuild(const std::vector<Contents>& contents, int node_shift, int submap_shift,
                            const ScanOf& scan_of) {
  std::vector<std::shared_ptr<Submap>> rebuilt;
  for (const Contents& c : contents) {
    if (c.members.empty()) throw std::invalid_argument("an active submap without insertions");
    auto submap =
        std::make_shared<Submap>(c.index - submap_shift, c.members.front().node - node_shift,
                                 c.anchor_pose, paramsOf(c.index));
    for (const Submap::Member& m : c.members) {
      const int node = m.node - node_shift;
      submap->insert(scan_of(node), m.local_pose, node);
    }
    rebuilt.push_back(std::move(submap));
  }
  active_ = std::move(rebuilt);
  next_index_ -= submap_shift;
  first_index_ -= submap_shift;  // trimming removes submaps before the active ones only
}

void ActiveSubmaps::startYouth() {
  young_ = true;
  for (auto& submap : active_) {
    if (submap->index() == first_index_) submap->setYoungScans(params_.young_submap_scans);
  }
}

SubmapParams ActiveSubmaps::paramsOf(int index) const {
  SubmapParams p = params_;
  if (index != first_index_ || !young_) p.young_submap_scans = 0;
  return p;
}

}  // namespace rrr_graphslam::frontend
