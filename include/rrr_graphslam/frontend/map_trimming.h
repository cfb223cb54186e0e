#pragma once
// Lifelong trimming of a map (Zhao et al., "A General Framework for Lifelong Localization and
// Mapping in Changing Environment", IROS 2021): a finished submap that newer submaps cover is
// trimmed, the nodes it owns leave the graph, and the information their constraints held about
// the rest stays as marginal constraints, so the map grows with the area it covers and not with
// the time spent in it.
//
// Steps, with the papers' names:
//   1. Coverage: every submap's observed cells (known in a grid of its scans inserted at their
//      map poses, at coverage_resolution_m). From the newest submap back, a submap is judged
//      against the union of the cells of the newer submaps that are kept: the overlap ratio
//      (Zhao et al.) or the fresh area (Cartographer's OverlappingSubmapsTrimmer2D), a
//      TrimmingStrategy. The newest keep_recent_submaps are never trimmed, nor (with
//      keep_current_session) the newest session's.
//   2. Owned nodes: a node leaves when every submap it was inserted into is trimmed (consecutive
//      submaps share half their scans: the nodes of a kept neighbour stay).
//   3. Marginalization (core/marginalization.h; the working graph is trim_graph.h) of each
//      trimmed submap's leaving nodes, oldest first (or, with group_neighbours, of each group of
//      leaving nodes that trusted constraints join), at the optimum of the trusted graph
//      (odometry, accepted loops and earlier marginal constraints), found once before the first
//      trim: the Schur complement over their Markov blanket, from the constraints touching them
//      only.
//   4. Sparsification: the Chow-Liu tree of that marginal (core/chow_liu.h) replaces it as
//      marginal constraints (kClt), the marginal itself does as dense factors, one per piece of
//      the blanket (kDense, core/dense_factor.h: exact; a later trim that touches one folds it
//      into its own marginal, so blankets grow where trims meet), or nothing does (kDelete,
//      Cartographer's trimmer).
//   5. Memory (map_memory.h): the cells the leaving scans of each session decide together are
//      kept, in 10 m tiles each anchored to the nearest node that stays, for the rendered map;
//      patches whose anchor leaves move to the nearest that stays; the cells a newer patch
//      decides are forgotten.
//
// RRR's verdicts: only trusted information is folded into marginal constraints. A submap with a
// node that a pending loop candidate touches waits (it is not trimmed until the loop is decided);
// rejected loops touching a removed node are dropped with it (they are no part of the map). An
// accepted loop folded into a marginal constraint can no longer be reversed: trim after the
// decisions are final (the end of a session, after RRR's decision from scratch), or, while a
// session runs (NewestSession::kRunning, online trimming), leave alone what its loops in open
// clusters touch.
//
// KL: for each trim, the Kullback-Leibler divergence of the graph with the replacement (and with
// plain deletion, for comparison) from the graph with the exact marginal (core/gaussian_kl.h),
// from the graph's covariance over the blanket.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "rrr_graphslam/core/chow_liu.h"
#include "rrr_graphslam/core/param_info.h"
#include "rrr_graphslam/frontend/map_render.h"
#include "rrr_graphslam/frontend/map_snapshot.h"
#include "rrr_graphslam/frontend/submap.h"

namespace rrr_graphslam::frontend {

/// What replaces a trimmed submap's constraints.
enum class Sparsification {
  kClt,     ///< the Chow-Liu tree of the marginal (default)
  kDense,   ///< the exact marginal, dense factors over the blanket (core/dense_factor.h)
  kDelete,  ///< nothing: their information is lost (Cartographer's trimmer)
};
inline core::Choices<Sparsification> choices(Sparsification /*tag*/) {
  return {{Sparsification::kClt, "clt"},
          {Sparsification::kDense, "dense"},
          {Sparsification::kDelete, "delete"}};
}
/// "clt", "dense", "delete".
std::string toString(Sparsification sparsification);
/// Parses "clt", "dense" or "delete"; std::invalid_argument otherwise.
Sparsification parseSparsification(const std::string& text);

/// The coverage rule that decides whether a submap is trimmed (a TrimmingStrategy).
enum class TrimRule {
  kOverlapRatio,  ///< Zhao et al.: the fraction of its cells newer kept submaps cover (default)
  kFreshArea,     ///< Cartographer's OverlappingSubmapsTrimmer2D: the area only it observes
};
inline core::Choices<TrimRule> choices(TrimRule /*tag*/) {
  return {{TrimRule::kOverlapRatio, "overlap-ratio"}, {TrimRule::kFreshArea, "fresh-area"}};
}
/// "overlap-ratio", "fresh-area".
std::string toString(TrimRule rule);
/// Parses "overlap-ratio" or "fresh-area"; std::invalid_argument otherwise.
TrimRule parseTrimRule(const std::string& text);

struct TrimParams {
  /// Which coverage rule trims a submap: the overlap ratio below, or the fresh area.
  TrimRule trim_rule = TrimRule::kOverlapRatio;
  /// A finished submap is trimmed when the newer kept submaps cover at least this fraction of its
  /// observed cells (Zhao et al.'s overlap ratio), in (0, 1].
  double trim_overlap_ratio = 0.9;
  /// With kFreshArea: a finished submap is trimmed when the area it observes and no newer kept
  /// submap does is below this (m^2, at least 0; Cartographer's min_covered_area, whose example
  /// configuration has 2).
  double trim_min_fresh_area_m2 = 2.0;
  /// The newest submaps are never trimmed; at least 1 (the submap being built).
  int keep_recent_submaps = 4;
  /// The submaps of the map's newest session with nodes (the one saving it, unless it added none)
  /// are never trimmed: they hold the
  /// newest view of every cell that session saw, so where the world changed the map shows it as
  /// it is now (trimming within the session would lose the cells its later submaps did not see
  /// again). Earlier sessions' submaps are judged against them. false: every submap is judged.
  bool keep_current_session = true;
  /// While a session runs (NewestSession::kRunning), a submap of its own is judged only against
  /// its kept submaps that begin at least this many nodes after it ends: a revisit, not the
  /// submaps that follow it on the way, so the older submaps the session's next loops would
  /// close on stay until it comes back (LaserSlam::trimmed uses at least the loop search's
  /// min_node_separation, so online the gap is never 0). 0: against every newer kept submap.
  /// Node numbers count the nodes left after earlier trims: the gap is at least this many.
  int revisit_gap_nodes = 0;
  Sparsification sparsification = Sparsification::kClt;
  /// How the Chow-Liu tree is built (kClt): its conservative scaling, its measurements.
  core::ChowLiuParams chow_liu;
  /// Cell size of the coverage grids (m).
  double coverage_resolution_m = 0.1;
  /// true: the leaving nodes that trusted constraints join are marginalized together (one exact
  /// marginal, one tree, however many submaps they came from: the blanket can grow to hundreds
  /// of nodes); false (default): the nodes of each trimmed submap on their own, oldest first (a
  /// later trim may marginalize an earlier one's tree again).
  bool group_neighbours = false;
  /// Whether each trim's KL divergences are measured: an instrument of the benchmarks, not part
  /// of a trim (one covariance of the whole graph over the blanket per trim; on a large map it
  /// takes far longer than the trims themselves).
  bool report_kl = false;
  /// Threads that build the coverage grids and the remembered patches.
  int threads = 2;
  /// The map's memory (map_memory.h): the cells a trimmed submap's leaving scans decide stay in
  /// the rendered map wherever no newer session decides them (a remembered cell a newer patch
  /// decides is forgotten). false: they leave with the scans (Cartographer's trimmer); the memory
  /// the map holds is kept as it is.
  bool remember_trimmed_cells = true;
  /// Cell size of the remembered patches (m); the rendered map's default.
  double memory_resolution_m = 0.05;
  /// The evidence that decides a remembered cell: the rendered map's (--map-hit-probability,
  /// --map-miss-probability).
  MapRenderParams memory_evidence;
};

/// Throws std::invalid_argument naming the parameter out of range.
void validate(const TrimParams& params);

/// A submap's coverage by the newer submaps that are kept.
struct SubmapCoverage {
  int submap = 0;
  std::size_t observed_cells = 0;
  std::size_t covered_cells = 0;  ///< of its observed cells, those a newer kept submap observed
  double cell_area_m2 = 0.0;
};

/// The rule that decides from its coverage whether a submap is trimmed.
class TrimmingStrategy {
 public:
  virtual ~TrimmingStrategy() = default;
  virtual bool trim(const SubmapCoverage& coverage) const = 0;
  virtual std::string describe() const = 0;
};

/// Zhao et al.: trimmed when covered / observed >= ratio.
class OverlapRatioTrimming : public TrimmingStrategy {
 public:
  explicit OverlapRatioTrimming(double ratio) : ratio_(ratio) {}
  bool trim(const SubmapCoverage& coverage) const override;
  std::string describe() const override;

 private:
  double ratio_;
};

/// Cartographer's OverlappingSubmapsTrimmer2D (one fresh submap per cell): trimmed when the area
/// it alone observes, among itself and the newer kept submaps, is below `min_fresh_area_m2`.
class FreshAreaTrimming : public TrimmingStrategy {
 public:
  explicit FreshAreaTrimming(double min_fresh_area_m2) : min_area_(min_fresh_area_m2) {}
  bool trim(const SubmapCoverage& coverage) const override;
  std::string describe() const override;

 private:
  double min_area_;
};

/// The strategy `params` choose (trim_rule with its threshold).
std::unique_ptr<TrimmingStrategy> trimmingStrategy(const TrimParams& params);

/// One marginalization: a trimmed submap's leaving nodes (with group_neighbours: those of
/// neighbouring trimmed submaps that trusted constraints join).
struct TrimRecord {
  int submap = 0;               ///< the oldest of them (index in the map before trimming)
  int submaps = 0;              ///< how many trimmed submaps owned the nodes
  int removed_nodes = 0;        ///< nodes it owned that left the graph
  int blanket_nodes = 0;        ///< their Markov blanket
  int removed_constraints = 0;  ///< trusted constraints (and dense factors) folded into it
  int marginal_edges = 0;       ///< what replaced them (clt)
  int dense_factors = 0;        ///< what replaced them (dense: one per piece of the blanket)
  double kl_nats = 0.0;         ///< KL(exact marginal || the replacement used)
  double kl_clt_nats = 0.0;     ///< KL(exact marginal || Chow-Liu tree)
  double kl_delete_nats = 0.0;  ///< KL(exact marginal || deletion)
  /// The trim's own work: finding the constraints, marginalization, sparsification (the graph's
  /// optimization, shared by every trim, is TrimReport::optimize_seconds).
  double seconds = 0.0;
  /// The KL figures' measurement (a factorization of the whole graph and the blanket's
  /// covariance); 0 without TrimParams::report_kl.
  double kl_seconds = 0.0;
};

struct TrimReport {
  int trimmed_submaps = 0;               ///< some own no node (their kept neighbours hold them all)
  std::vector<TrimRecord> trims;         ///< one per group of removed nodes, oldest first
  std::vector<SubmapCoverage> coverage;  ///< every submap judged, newest first
  int waiting_submaps = 0;         ///< would be trimmed but a pending loop touches their nodes
  int dropped_rejected_loops = 0;  ///< rejected candidates that touched a removed node
  /// Marginal edges the trims made that are in the trimmed map (a later trim of the same run may
  /// marginalize an earlier one's edges again: marginalEdges() counts every one made).
  int marginal_edges_kept = 0;
  /// Dense factors in the trimmed map (the map's earlier ones included: each trim folds those it
  /// touches into its own).
  int dense_factors_kept = 0;
  double coverage_seconds = 0.0;
  /// The trusted graph's optimization before the trims (where they all linearize) and after
  /// (the trimmed map at its own minimum); with kDelete and report_kl, after each deletion too.
  double optimize_seconds = 0.0;
  /// The memory: patches made of this trim's leaving scans, remembered cells in the trimmed
  /// map, cells forgotten because newer patches decide them, and the time it all took.
  int remembered_patches = 0;
  std::size_t remembered_cells = 0;
  std::size_t forgotten_cells = 0;
  double memory_seconds = 0.0;
  double seconds = 0.0;  ///< everything
  int removedNodes() const;
  int marginalEdges() const;
};

struct TrimResult {
  MapSnapshot map;  ///< the trimmed map; its nodes renumbered in order
  TrimReport report;
  /// Per node of the input map: its index in the trimmed map, -1 if it left.
  std::vector<int> node_index;
  /// Per submap of the input map: its index in the trimmed map, -1 if it was trimmed.
  std::vector<int> submap_index;
};

/// Whether the map's newest session is over.
enum class NewestSession {
  /// Its decisions are final (a map being saved, between sessions): keep_current_session applies.
  kFinished,
  /// It is still mapping (online trimming): keep_current_session applies too (false: its older
  /// submaps are judged against its newer ones, so that one endless session stops growing; the
  /// caller keeps the submaps still being built within keep_recent_submaps), and a submap whose
  /// nodes a loop candidate in an open cluster touches waits, as for a pending loop (RRR still
  /// decides it as the cluster grows). The loops of closed clusters are taken as decided: an
  /// accepted one folded into a marginal constraint can no longer be reversed.
  kRunning,
};

/// Trims `map` (see above). `submap_params` are those the map's submaps were made with (their
/// insertion rules make the coverage grids). Throws std::invalid_argument for parameters out of
/// range or a map that fails MapSnapshot::check().
TrimResult trimMap(const MapSnapshot& map, const TrimParams& params,
                   const TrimmingStrategy& strategy, const SubmapParams& submap_params,
                   NewestSession newest = NewestSession::kFinished);
/// The same with trimmingStrategy(params).
TrimResult trimMap(const MapSnapshot& map, const TrimParams& params,
                   const SubmapParams& submap_params,
                   NewestSession newest = NewestSession::kFinished);

}  // namespace rrr_graphslam::frontend
