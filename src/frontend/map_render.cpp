#include "rrr_graphslam/frontend/map_render.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <stdexcept>
#include <tuple>

#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/frontend/map_io.h"

namespace rrr_graphslam::frontend {
namespace {
constexpr unsigned char kUnknownPixel = 205;  // map_io.h's mapServerPixel
// The most cells a rendered map may have (2^28: 800 m x 800 m at 5 cm, 512 MiB of MRPT's cells).
constexpr double kMaxRenderedCells = 268435456.0;

// Whether a ray touched the cell (MRPT's cells start at exactly 0.5).
bool observed(float free_probability) { return std::abs(free_probability - 0.5F) > 1e-3F; }

// Whether a map_server reader sees the cell occupied or free (MRPT's getCell(): p(free)).
bool decides(float free_probability) {
  return mapServerPixel(1.0F - free_probability) != kUnknownPixel;
}

// A patch of the memory placed in the map at its anchor's map pose.
struct PlacedPatch {
  const RememberedCells* patch = nullptr;
  core::Pose2 pose = core::Pose2::Zero();  // the patch frame in the map frame
  Eigen::Vector2d low, high;               // its footprint's bounding box
};

PlacedPatch place(const RememberedCells& patch, const std::vector<core::Pose2>& poses) {
  PlacedPatch placed;
  placed.patch = &patch;
  placed.pose = patchPose(patch, poses.at(static_cast<std::size_t>(patch.anchor_node)));
  const double w = patch.width * patch.resolution_m;
  const double h = patch.height * patch.resolution_m;
  const double c = std::cos(placed.pose.z());
  const double s = std::sin(placed.pose.z());
  placed.low = placed.high = placed.pose.head<2>();
  for (const auto& [u, v] : {std::pair{w, 0.0}, std::pair{0.0, h}, std::pair{w, h}}) {
    const Eigen::Vector2d corner(placed.pose.x() + c * u - s * v, placed.pose.y() + s * u + c * v);
    placed.low = placed.low.cwiseMin(corner);
    placed.high = placed.high.cwiseMax(corner);
  }
  return placed;
}

// A grid cell's view of a patch: the decided patch cells under it (index in the patch, value).
struct Samples {
  std::size_t n = 0;
  std::array<std::pair<std::size_t, std::uint8_t>, 16> cells;
};

// Calls f(cx, cy, samples) for every grid cell over which the patch has decided cells: the patch
// is sampled from the grid's side (so a patch turned by the graph's re-optimization leaves no
// holes) at 1 point per cell, or, where the grid is coarser than the patch, at up to 4 x 4 points
// spread over the cell, so that a thin wall of the patch is not missed between them.
template <class F>
void forEachRemembered(const mrpt::maps::COccupancyGridMap2D& grid, const PlacedPatch& placed,
                       F&& f) {
  const RememberedCells& patch = *placed.patch;
  const int x0 = std::max(0, grid.x2idx(placed.low.x()));
  const int x1 = std::min(static_cast<int>(grid.getSizeX()) - 1, grid.x2idx(placed.high.x()));
  const int y0 = std::max(0, grid.y2idx(placed.low.y()));
  const int y1 = std::min(static_cast<int>(grid.getSizeY()) - 1, grid.y2idx(placed.high.y()));
  const double c = std::cos(placed.pose.z());
  const double s = std::sin(placed.pose.z());
  const double r = grid.getResolution();
  const int per_side =
      static_cast<int>(std::clamp(std::ceil(r / patch.resolution_m - 1e-6), 1.0, 4.0));
  const std::vector<std::uint8_t>& cells = *patch.cells;
  Samples samples;
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      samples.n = 0;
      for (int a = 0; a < per_side; ++a) {
        for (int b = 0; b < per_side; ++b) {
          // The sample point in the map frame, then in the patch frame.
          const double dx = grid.idx2x(cx) + r * ((a + 0.5) / per_side - 0.5) - placed.pose.x();
          const double dy = grid.idx2y(cy) + r * ((b + 0.5) / per_side - 0.5) - placed.pose.y();
          const double i = std::floor((c * dx + s * dy) / patch.resolution_m);
          const double j = std::floor((-s * dx + c * dy) / patch.resolution_m);
          if (i < 0 || j < 0 || i >= patch.width || j >= patch.height) continue;
          const std::size_t k =
              static_cast<std::size_t>(j) * static_cast<std::size_t>(patch.width) +
              static_cast<std::size_t>(i);
          if (cells[k] != RememberedCells::kUnknown) samples.cells[samples.n++] = {k, cells[k]};
        }
      }
      if (samples.n > 0) f(cx, cy, samples);
    }
  }
}

// What a rendering made of the memory, per patch and cell: superseded (a decision a newer layer
// (a newer session's scans or patch, or a later patch of the same session) decides over, and that
// shows nowhere; evidence under a newer decision, or added to a newer patch's evidence), and the
// evidence of older patches added to the cell.
struct MemoryUse {
  std::vector<std::vector<char>> superseded;
  std::vector<std::vector<float>> added;
};

// The grid a rendering starts from: the trajectory's and the patches' bounding box (MRPT grows it
// to fit the rays; the log's odometry origin may lie hundreds of metres away). Throws for a map
// beyond the cell budget.
mrpt::maps::COccupancyGridMap2D emptyGrid(const MapInputs& inputs,
                                          const std::vector<PlacedPatch>& placed,
                                          double resolution_m) {
  const std::vector<core::Pose2>& map = inputs.poses;
  Eigen::Vector2d low(-1.0, -1.0);
  Eigen::Vector2d high(1.0, 1.0);
  if (!map.empty()) {
    low = high = map.front().head<2>();
    for (const auto& x : map) {
      low = low.cwiseMin(x.head<2>());
      high = high.cwiseMax(x.head<2>());
    }
  }
  for (const PlacedPatch& p : placed) {
    low = low.cwiseMin(p.low);
    high = high.cwiseMax(p.high);
  }
  // MRPT counts a grid's cells in 32 bits, and the rays grow it by up to their range on each
  // side: a map beyond the budget is refused before any grid is built.
  const double margin = 1.0 + inputs.insertion.max_insertion_range_m;
  const double span_cells = (high.x() - low.x() + 2.0 * margin) / resolution_m *
                            ((high.y() - low.y() + 2.0 * margin) / resolution_m);
  if (!(span_cells <= kMaxRenderedCells)) {
    throw std::invalid_argument(
        "the map spans " + std::to_string(high.x() - low.x()) + " m x " +
        std::to_string(high.y() - low.y()) + " m: more than " + std::to_string(kMaxRenderedCells) +
        " cells of " + std::to_string(resolution_m) + " m with its rays; render it coarser");
  }
  return mrpt::maps::COccupancyGridMap2D(
      static_cast<float>(low.x() - 1.0), static_cast<float>(high.x() + 1.0),
      static_cast<float>(low.y() - 1.0), static_cast<float>(high.y() + 1.0),
      static_cast<float>(resolution_m));
}

// The layers of a rendered map, painted newest first (map_render.h): each session's kept scans,
// then its patches. A cell keeps the first layer that decides it (a map_server reader would see
// it occupied or free: a glimpse does not overrule an older session's clear view); where none
// does, the patches' evidence adds to the kept scans' (addEvidence). With `record_use`, what the
// rendering made of every remembered cell is recorded for forgetSuperseded().
class Layers {
 public:
  // `all_scans`: every kept scan in one grid (the fallback where no layer decides a cell);
  // `scans_decide`: every scan alike (kAllScans), so the patches fill only what it leaves unknown.
  Layers(const std::vector<PlacedPatch>& placed, const mrpt::maps::COccupancyGridMap2D& all_scans,
         bool scans_decide, bool record_use)
      : placed_(placed),
        grid_(all_scans),
        layered_(all_scans),
        taken_(cellCount(), 0),
        won_(placed.size()),
        lost_(placed.size()),
        owner_(placed.size()),
        fused_(placed.size()),
        evidence_(placed.empty() ? 0 : cellCount(), 0.0F),
        has_evidence_(evidence_.size(), 0),
        record_use_(record_use),
        evidence_owner_(record_use ? evidence_.size() : 0, {-1, 0}) {
    if (record_use_) use_.added.assign(placed.size(), {});
    if (!scans_decide) return;
    for (unsigned cy = 0; cy < grid_.getSizeY(); ++cy) {
      for (unsigned cx = 0; cx < grid_.getSizeX(); ++cx)
        taken_[index(cx, cy)] = decides(grid_.getCell(cx, cy));
    }
  }

  // One session's kept scans (`own`, a grid of the rendering's size) decide the cells no newer
  // layer decided.
  void paintSession(const mrpt::maps::COccupancyGridMap2D& own) {
    for (unsigned cy = 0; cy < own.getSizeY(); ++cy) {
      for (unsigned cx = 0; cx < own.getSizeX(); ++cx) {
        char& t = taken_[index(cx, cy)];
        const float p = own.getCell(cx, cy);
        if (t || !decides(p)) continue;
        layered_.setCell(cx, cy, p);
        t = 1;
      }
    }
  }

  // Patch p: its decisions where no newer layer decided the cell (won, else lost); its evidence
  // (lost under a decision) kept per grid cell for addEvidence, with its owner (the newest
  // evidence of the cell, to which older evidence is added) or fused (added to the owner).
  void paintPatch(std::size_t p) {
    const std::size_t n_cells = placed_[p].patch->cells->size();
    if (record_use_) {
      for (auto* flags : {&won_, &lost_, &owner_, &fused_}) (*flags)[p].assign(n_cells, 0);
      use_.added[p].assign(n_cells, 0.0F);
    }
    forEachRemembered(grid_, placed_[p], [&](int cx, int cy, const Samples& samples) {
      const std::size_t g = index(cx, cy);
      paintDecisions(p, cx, cy, samples);
      // The patch's glimpse of the grid cell, once per patch (the mean of its samples: a ray
      // updates a coarse cell once, not once per fine cell).
      float glimpse = 0.0F;
      int glimpses = 0;
      for (std::size_t n = 0; n < samples.n; ++n) {
        const auto [k, v] = samples.cells[n];
        if (isDecision(v)) continue;
        if (taken_[g]) {
          if (record_use_) lost_[p][k] = 1;
          continue;
        }
        glimpse += evidenceLogOdds(v);
        ++glimpses;
      }
      if (glimpses == 0) return;
      evidence_[g] += glimpse / static_cast<float>(glimpses);
      has_evidence_[g] = 1;
      if (record_use_) recordEvidence(p, g, samples, glimpses);
    });
  }

  // Where no layer decides a cell, the patches' evidence adds to the kept scans' (every scan
  // alike, as the untrimmed map's scans would add up).
  void addEvidence() {
    for (unsigned cy = 0; !evidence_.empty() && cy < grid_.getSizeY(); ++cy) {
      for (unsigned cx = 0; cx < grid_.getSizeX(); ++cx) {
        const std::size_t g = index(cx, cy);
        if (taken_[g] || !has_evidence_[g]) continue;
        const float p =
            freeProbabilityOfLogOdds(occupancyLogOdds(layered_.getCell(cx, cy)) + evidence_[g]);
        if (decides(p)) layered_.setCell(cx, cy, p);
      }
    }
  }

  // The rendered map, once every layer was painted.
  mrpt::maps::COccupancyGridMap2D takeMap() && { return std::move(layered_); }

  // What the rendering made of the memory; only with `record_use`, after every patch was painted.
  MemoryUse takeMemoryUse() {
    assert(record_use_);
    // A cell that owns the evidence of some grid cell stays in its patch, with all of its
    // evidence: it is not also added to another owner (a coarse or turned older cell can
    // straddle grid cells with and without newer evidence; adding it there too would count it
    // twice, and again at every later forgetting).
    // An older cell and an owner cell that both cover several grid cells meet in each of them:
    // the older cell's evidence is added to that owner once (the first meeting's), as the owner
    // shows it in all of them.
    std::stable_sort(fusions_.begin(), fusions_.end(),
                     [](const Fusion& a, const Fusion& b) { return a.pair() < b.pair(); });
    for (std::size_t i = 0; i < fusions_.size(); ++i) {
      const Fusion& f = fusions_[i];
      const bool again = i > 0 && fusions_[i - 1].pair() == f.pair();
      if (again || owner_[f.patch][f.cell]) continue;
      use_.added[f.owner_patch][f.owner_cell] += f.evidence;
    }
    use_.superseded.assign(placed_.size(), {});
    for (std::size_t p = 0; p < placed_.size(); ++p) {
      const std::vector<std::uint8_t>& cells = *placed_[p].patch->cells;
      std::vector<char>& out = use_.superseded[p];
      out.assign(cells.size(), 0);
      for (std::size_t k = 0; k < out.size(); ++k) {
        out[k] = isDecision(cells[k]) ? lost_[p][k] && !won_[p][k]
                                      : (lost_[p][k] || fused_[p][k]) && !owner_[p][k];
      }
    }
    return std::move(use_);
  }

 private:
  std::size_t cellCount() const {
    return static_cast<std::size_t>(grid_.getSizeX()) * grid_.getSizeY();
  }
  std::size_t index(unsigned cx, unsigned cy) const {
    return static_cast<std::size_t>(cy) * grid_.getSizeX() + cx;
  }

  // The cell as a scan would leave it: occupied where a wall of the patch lies in it.
  void paintDecisions(std::size_t p, int cx, int cy, const Samples& samples) {
    char& t = taken_[index(cx, cy)];
    float most_occupied = 1.0F;
    bool decision = false;
    for (std::size_t n = 0; n < samples.n; ++n) {
      const auto [k, v] = samples.cells[n];
      if (!isDecision(v)) continue;
      decision = true;
      if (record_use_) (t ? lost_ : won_)[p][k] = 1;
      most_occupied = std::min(most_occupied, freeProbability(v));
    }
    if (decision && !t) {
      layered_.setCell(cx, cy, most_occupied);
      t = 1;
    }
  }

  // The first patch with evidence in grid cell g owns it; a later (older) patch's evidence there
  // is to be added to the owner's cell, as the rendering adds it to g (a coarse older cell to
  // the owner of every grid cell it covers), unless the older cell owns another grid cell
  // (takeMemoryUse).
  void recordEvidence(std::size_t p, std::size_t g, const Samples& samples, int glimpses) {
    auto& [owner_patch, owner_cell] = evidence_owner_[g];
    for (std::size_t n = 0; n < samples.n; ++n) {
      const auto [k, v] = samples.cells[n];
      if (isDecision(v)) continue;
      if (owner_patch < 0) {
        owner_patch = static_cast<int>(p);
        owner_cell = k;
        owner_[p][k] = 1;
      } else if (static_cast<std::size_t>(owner_patch) != p) {
        fused_[p][k] = 1;
        fusions_.push_back({p, k, static_cast<std::size_t>(owner_patch), owner_cell,
                            evidenceLogOdds(v) / static_cast<float>(glimpses)});
      }
    }
  }

  const std::vector<PlacedPatch>& placed_;
  const mrpt::maps::COccupancyGridMap2D& grid_;
  mrpt::maps::COccupancyGridMap2D layered_;
  std::vector<char> taken_;  // per grid cell: a layer decided it
  // Per patch and cell, with record_use only (forgetting): decisions won (shown) or lost (a newer
  // layer decided the cell); evidence lost (under a decision), owner or fused.
  std::vector<std::vector<char>> won_, lost_, owner_, fused_;
  // Per grid cell, only with a memory: the patches' evidence where no layer decides.
  std::vector<float> evidence_;
  std::vector<char> has_evidence_;
  bool record_use_;
  std::vector<std::pair<int, std::size_t>> evidence_owner_;  // per grid cell: (patch, cell)
  // An older cell's evidence to add to a grid cell's owner (patch, cell), with record_use only.
  struct Fusion {
    std::size_t patch, cell;
    std::size_t owner_patch, owner_cell;
    float evidence;
    std::tuple<std::size_t, std::size_t, std::size_t, std::size_t> pair() const {
      return {patch, cell, owner_patch, owner_cell};
    }
  };
  std::vector<Fusion> fusions_;
  MemoryUse use_;
};

mrpt::maps::COccupancyGridMap2D render(const MapInputs& inputs, double resolution_m,
                                       MemoryUse* use) {
  if (inputs.render) validate(*inputs.render);
  const std::vector<core::Pose2>& map = inputs.poses;
  for (const RememberedCells& patch : inputs.memory) {
    patch.check(static_cast<int>(map.size()));
  }
  std::vector<PlacedPatch> placed;
  for (const RememberedCells& patch : inputs.memory) placed.push_back(place(patch, map));
  mrpt::maps::COccupancyGridMap2D grid = emptyGrid(inputs, placed, resolution_m);
  SubmapParams insertion = inputs.insertion;
  if (inputs.render) {
    insertion.hit_probability = static_cast<float>(inputs.render->hit_probability);
    insertion.miss_probability = static_cast<float>(inputs.render->miss_probability);
  }
  configureInsertion(grid, insertion);
  const std::size_t nodes = std::min(inputs.scans.size(), map.size());
  auto insert = [&](mrpt::maps::COccupancyGridMap2D& into, std::size_t k) {
    const core::Pose2& x = map[k];
    into.insertObservation(*inputs.scans[k], mrpt::poses::CPose3D(x.x(), x.y(), 0.0, x.z(), 0, 0));
  };
  for (std::size_t k = 0; k < nodes; ++k) insert(grid, k);
  const bool by_session = inputs.layering == MapLayering::kNewestSession || use;
  const bool one_session = inputs.sessions.size() < nodes;
  std::set<int, std::greater<>> session_numbers;  // newest first
  if (!one_session)
    session_numbers.insert(inputs.sessions.begin(), inputs.sessions.begin() + nodes);
  if (placed.empty() && (!by_session || session_numbers.size() < 2)) return grid;

  Layers layers(placed, grid, !by_session, use != nullptr);
  // One session's kept scans in a grid of their own.
  auto paintSession = [&](int session) {
    mrpt::maps::COccupancyGridMap2D own(grid.getXMin(), grid.getXMax(), grid.getYMin(),
                                        grid.getYMax(), grid.getResolution());
    configureInsertion(own, insertion);
    bool any = false;
    for (std::size_t k = 0; k < nodes; ++k) {
      if (!one_session && inputs.sessions[k] != session) continue;
      insert(own, k);
      any = true;
    }
    if (any && own.getSizeX() == grid.getSizeX() && own.getSizeY() == grid.getSizeY())
      layers.paintSession(own);
  };
  // The patches newest first: by session, then the later patch first.
  std::vector<std::size_t> patch_order(placed.size());
  for (std::size_t p = 0; p < placed.size(); ++p) patch_order[p] = p;
  std::stable_sort(patch_order.begin(), patch_order.end(), [&](std::size_t a, std::size_t b) {
    const int sa = inputs.memory[a].session;
    const int sb = inputs.memory[b].session;
    return sa != sb ? sa > sb : a > b;
  });
  auto next_patch = patch_order.begin();
  if (by_session) {
    if (one_session) session_numbers.insert(std::numeric_limits<int>::max());
    for (int session : session_numbers) {
      // Patches of newer sessions than this one (a session that left the map whole).
      for (; next_patch != patch_order.end() && inputs.memory[*next_patch].session > session;
           ++next_patch) {
        layers.paintPatch(*next_patch);
      }
      paintSession(session);
    }
  }
  for (; next_patch != patch_order.end(); ++next_patch) layers.paintPatch(*next_patch);
  layers.addEvidence();
  if (use) *use = layers.takeMemoryUse();
  return std::move(layers).takeMap();
}

// The smallest box of cells (x, y) in [x_begin, x_end) x [y_begin, y_end) where keep(x, y) holds;
// empty() if there is none.
struct CellBox {
  int x0 = std::numeric_limits<int>::max(), x1 = -1;
  int y0 = std::numeric_limits<int>::max(), y1 = -1;
  bool empty() const { return x1 < 0; }
};

template <class Keep>
CellBox boundsOf(int x_begin, int x_end, int y_begin, int y_end, Keep&& keep) {
  CellBox box;
  for (int y = y_begin; y < y_end; ++y) {
    for (int x = x_begin; x < x_end; ++x) {
      if (!keep(x, y)) continue;
      box.x0 = std::min(box.x0, x);
      box.x1 = std::max(box.x1, x);
      box.y0 = std::min(box.y0, y);
      box.y1 = std::max(box.y1, y);
    }
  }
  return box;
}

// The patch of `grid`'s decided cells within [x0, x1] x [y0, y1], anchored as asked.
RememberedCells patchOf(const mrpt::maps::COccupancyGridMap2D& grid, int x0, int x1, int y0, int y1,
                        int session, int anchor_node, const core::Pose2& anchor_map_pose) {
  RememberedCells patch;
  patch.session = session;
  patch.anchor_node = anchor_node;
  patch.resolution_m = grid.getResolution();
  patch.width = x1 - x0 + 1;
  patch.height = y1 - y0 + 1;
  const double r = grid.getResolution();
  const core::Pose2 corner(grid.getXMin() + x0 * r, grid.getYMin() + y0 * r, 0.0);
  patch.origin = core::between(anchor_map_pose, corner);
  auto cells = std::make_shared<std::vector<std::uint8_t>>(
      static_cast<std::size_t>(patch.width) * static_cast<std::size_t>(patch.height),
      RememberedCells::kUnknown);
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      const float p = grid.getCell(cx, cy);
      if (!observed(p)) continue;
      (*cells)[static_cast<std::size_t>(cy - y0) * static_cast<std::size_t>(patch.width) +
               static_cast<std::size_t>(cx - x0)] = rememberedValue(p);
    }
  }
  patch.cells = std::move(cells);
  return patch;
}

}  // namespace

void validate(const MapRenderParams& params) {
  forEachMapRenderParam(params, [](const core::ParamInfo& info, const auto& value) {
    core::checkRange(info, value);
  });
}

mrpt::maps::COccupancyGridMap2D renderOccupancyMap(const MapInputs& inputs, double resolution_m) {
  return render(inputs, resolution_m, nullptr);
}

std::vector<RememberedCells> rememberScans(const MapInputs& inputs, double resolution_m,
                                           int session, double tile_m, const PatchAnchor& anchor) {
  MapInputs scans = inputs;
  scans.memory.clear();
  scans.sessions.clear();
  scans.layering = MapLayering::kAllScans;
  if (!scans.render) scans.render = MapRenderParams{};
  const mrpt::maps::COccupancyGridMap2D grid = renderOccupancyMap(scans, resolution_m);
  const int size_x = static_cast<int>(grid.getSizeX());
  const int size_y = static_cast<int>(grid.getSizeY());
  const int tile = std::max(1, static_cast<int>(std::lround(tile_m / grid.getResolution())));
  std::vector<RememberedCells> patches;
  for (int ty = 0; ty < size_y; ty += tile) {
    for (int tx = 0; tx < size_x; tx += tile) {
      const CellBox box = boundsOf(tx, std::min(tx + tile, size_x), ty, std::min(ty + tile, size_y),
                                   [&](int cx, int cy) { return observed(grid.getCell(cx, cy)); });
      if (box.empty()) continue;
      const Eigen::Vector2d centre(0.5 * (grid.idx2x(box.x0) + grid.idx2x(box.x1)),
                                   0.5 * (grid.idx2y(box.y0) + grid.idx2y(box.y1)));
      const auto [node, node_pose] = anchor(centre);
      patches.push_back(patchOf(grid, box.x0, box.x1, box.y0, box.y1, session, node, node_pose));
    }
  }
  return patches;
}

std::vector<RememberedCells> forgetSuperseded(const std::vector<RememberedCells>& memory,
                                              const std::vector<core::Pose2>& poses,
                                              double resolution_m) {
  if (memory.empty()) return {};
  // The patches alone, newest first. The kept scans are left out: a remembered cell a kept
  // session decides is hidden while that session's scans stay, but the patches made of them when
  // they leave may not decide it (not all of them leave at once).
  MapInputs patches;
  patches.poses = poses;
  patches.memory = memory;
  patches.layering = MapLayering::kNewestSession;
  MemoryUse use;
  render(patches, resolution_m, &use);
  const std::vector<std::vector<char>>& superseded = use.superseded;
  std::vector<RememberedCells> kept;
  for (std::size_t p = 0; p < memory.size(); ++p) {
    const RememberedCells& patch = memory[p];
    const std::vector<std::uint8_t>& cells = *patch.cells;
    const CellBox box = boundsOf(0, patch.width, 0, patch.height, [&](int i, int j) {
      const std::size_t k = static_cast<std::size_t>(j) * patch.width + i;
      return cells[k] != RememberedCells::kUnknown && !superseded[p][k];
    });
    if (box.empty()) continue;  // a newer patch has all of it
    const auto [x0, x1, y0, y1] = box;
    RememberedCells out = patch;
    out.width = x1 - x0 + 1;
    out.height = y1 - y0 + 1;
    out.origin = core::compose(patch.origin,
                               core::Pose2(x0 * patch.resolution_m, y0 * patch.resolution_m, 0.0));
    auto left = std::make_shared<std::vector<std::uint8_t>>(
        static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height),
        RememberedCells::kUnknown);
    for (int j = y0; j <= y1; ++j) {
      for (int i = x0; i <= x1; ++i) {
        const std::size_t k = static_cast<std::size_t>(j) * patch.width + i;
        if (superseded[p][k]) continue;
        const float added = use.added[p].empty() ? 0.0F : use.added[p][k];
        (*left)[static_cast<std::size_t>(j - y0) * out.width + (i - x0)] =
            added == 0.0F || isDecision(cells[k])
                ? cells[k]
                : rememberedValue(freeProbabilityOfLogOdds(evidenceLogOdds(cells[k]) + added));
      }
    }
    out.cells = std::move(left);
    kept.push_back(std::move(out));
  }
  return kept;
}

MapInputs renderInputs(const MapSnapshot& map) {
  MapInputs inputs;
  for (const MapSnapshot::Node& node : map.nodes) {
    inputs.poses.push_back(node.map_pose);
    inputs.scans.push_back(node.scan);
    inputs.sessions.push_back(map.sessions.at(static_cast<std::size_t>(node.session)).number);
  }
  inputs.memory = map.memory;
  return inputs;
}

std::string toString(MapLayering layering) { return core::choiceName(layering); }

MapLayering parseMapLayering(const std::string& text) {
  return core::parseChoiceOrThrow<MapLayering>(text, "map layering");
}

}  // namespace rrr_graphslam::frontend
