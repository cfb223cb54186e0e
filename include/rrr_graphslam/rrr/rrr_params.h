#pragma once
// RRR's parameters: one definition of each (name, default, range, doc line) in forEachParam(),
// which rrr_offline (--name-with-dashes), the ROS nodelet (~name) and config/rrr_graphslam.yaml
// all follow, and one validate() whose message every entry point prints (core/param_info.h).
//
// The published algorithm (Latif, Cadena, Neira, IJRR 2013) is the `paper` preset: every addition
// below switched off. `default` switches them on; doc/rrr_extensions.md gives, for each, the
// failure it fixes and the measurement behind it.

#include <limits>
#include <string>
#include <vector>

#include "rrr_graphslam/core/optimizer.h"
#include "rrr_graphslam/core/param_info.h"

namespace rrr_graphslam::rrr {

struct RrrParams {
  // --- The paper's parameters.
  /// Confidence of every chi-square test; default 0.95 (the paper's).
  double alpha = 0.95;
  /// Clustering gap in nodes (the paper's t_g); default 0 = derived from the candidates
  /// (deriveClusterGap).
  int cluster_gap = 0;
  /// Realize/reverse/recover rounds per decision, at most; default 50.
  int max_rounds = 50;

  // --- Additions to the intra-cluster test (Algorithm 1).
  /// Intra tests on the reduced graph (only the nodes the links touch, joined by compounded
  /// odometry) instead of the whole graph; default true (paper: the whole graph).
  bool reduced_intra_graph = true;
  /// A cluster whose joint test fails loses its worst link and is tested again, instead of
  /// failing whole; default true.
  bool intra_worst_link_removal = true;
  /// A cluster that fails its intra test as a whole is split into sets of pairwise consistent
  /// links (pairwise_consistency.h), each a cluster of its own; default true.
  bool split_mixed_clusters = true;

  // --- Additions to realize / reverse / recover (Algorithms 2 and 3).
  /// A batch decision tests first the clusters that agree with a robust (DCS) map and sends the
  /// others to the recover step; default true (paper: every candidate cluster at once).
  bool robust_ordering = true;
  /// Dynamic Covariance Scaling parameter of that robust map; default 1.
  double dcs_phi = 1.0;
  /// Joint tests start from the good set's map (recover rounds) and, in batch, each removal round
  /// goes on from the previous round's solution (online every round restarts from the good map);
  /// default true (paper: every optimization starts from the initial estimate).
  bool warm_start = true;
  /// A joint test may remove good clusters as well as the hypotheses it tests (reverse); default
  /// true (paper, as in the authors' implementation: only the hypotheses can be removed).
  bool reverse_good_clusters = true;
  /// Inter-cluster: also remove clusters whose consistency index is at least this fraction of the
  /// worst; default 0.5 (paper: 1, one cluster per optimization).
  double batch_removal_fraction = 0.5;
  /// Inter-cluster, when only the joint test fails (every cluster's index below 1): remove the
  /// cluster whose removal is predicted to lower the chi2 most (its leave-one-out index, if at
  /// least 1), not the one of highest index, which a large false group that bends the map toward
  /// itself never is; default true (paper: the highest index).
  bool conflict_removal = true;
  /// After realizing, the good set is optimized again from LAGO's estimate, which wins if its
  /// chi2 is lower by more than chi2(alpha, 3); default true.
  bool settle_good_map = true;
  /// Recover: when the good set grew, retry a rejected cluster jointly only when its consistency
  /// index against the good set's map, without moving any pose, is below this (the clusters just
  /// removed included); default 10. Infinity is the paper's rule: every cluster rejected before
  /// the round returns to the hypotheses.
  double recover_gate = 10.0;
  /// Recover, far: a rejected cluster of at least this many links that the recover gate keeps
  /// out is still tested once per decision with the good set if its linearized joint test at the
  /// good map passes the gate, and accepted only as is (nothing removed, the good set's chi2
  /// raised by less than chi2(alpha, its dof)). Default 10; 0: never (paper).
  int far_retry_min_links = 10;
  /// After a batch decision, a good cluster whose removal would lower the chi2 by more than
  /// chi2(alpha, dof) (linearized) is rejected; default true.
  bool leave_one_out_check = true;
  /// The leave-one-out check examines good clusters whose own consistency index is at least this,
  /// and those of far_retry_min_links links or more; default 0.1 (0 examines all).
  double loo_min_index = 0.1;
  /// Joint leave-out: after the leave-one-out check rejects nothing, the examined clusters whose
  /// leave-one-out index is at least this are left out together; if their joint index reaches 1,
  /// the one of the highest own leave-one-out index is rejected and the check runs again (two
  /// false groups can each hold the other's bend, so that neither fails alone); default 0.2
  /// (paper: 0, off).
  double loo_joint_min_index = 0.2;
  /// After a batch decision, links of good clusters that fail the per-link chi-square test at
  /// the good set's joint solution are dropped; default true.
  bool joint_link_check = true;
  /// Multi-session graphs: a batch decision starts from an estimate in which each later session
  /// is moved rigidly onto the placed ones by the largest cluster joining them, instead of its
  /// own odometry frame (which says nothing of where it lies in the others'); default true.
  bool place_sessions = true;
  /// Multi-session graphs: a session is tied to the map only by a group of its joining clusters
  /// that agree with one another and whose ends in the session lie at least this far apart (m);
  /// the others wait (pending) until such a group exists (session_placement.h). 0: any cluster
  /// that passes the tests ties a session (paper). LaserSlam sets it to the front end's
  /// relocalization_confirm_distance_m; default 0.
  double placement_min_spread_m = 0.0;
  /// With placement_min_spread_m: the group must also have at least this many times the clusters
  /// of the largest group that agrees with none of them (another reading of where the session
  /// lies, session_placement.h: outnumbersRival); until then both wait. Default 1: the larger
  /// group places the session however close the other (2 is measured in
  /// doc/rrr_extensions.md#two-readings-of-one-place: safer, later ties).
  double placement_min_ratio = 1.0;
  /// With placement_min_spread_m: of the largest agreeing group and its rival, the one the session
  /// saw over the longer stretch places it (session_placement.h: preferWiderReading); default
  /// true; false: the one with more clusters.
  bool placement_wider_reading = true;

  // --- Incremental RRR.
  /// A new cluster that fits the good set's map unchanged (index < 1) is accepted, and one whose
  /// linearized joint test fails is rejected, without a joint optimization; default true (paper:
  /// every new cluster gets the joint test).
  bool online_map_check = true;
  /// With online_map_check: a cluster left with one link after its intra test, both ends in one
  /// session, that the map would have to move to fit (it needs the joint test) waits (pending,
  /// checked again at later decisions, decided at the latest by the next decision from scratch)
  /// while the map leaves its relative pose open: more uncertain, in some direction, than this
  /// many times the link's own covariance (linearized_tests.h: mapUncertaintyRatio). A lone link
  /// whose end hangs from the map by odometry alone (the robot's path since its last long loop)
  /// passes the joint test wherever it points; once later loops hold that path it is tested.
  /// Clusters of several links test one another (intra-cluster) and are decided at once; links
  /// between sessions are left to the placement rules. Default 100; 0: off (paper).
  double online_untestable_ratio = 100.0;
  /// With online_untestable_ratio: a cluster of several links, every one between nodes more than
  /// this many apart (a revisit, not a loop within the robot's recent path), both ends in one
  /// session, that the map would have to move to fit and whose relative pose it leaves open waits
  /// up to this many nodes after its newest link for a second such cluster. The waiting clusters
  /// are tested jointly with the good set and accepted only when at least two of them pass, no
  /// good cluster is reversed, and their increase of D2_G stays below chi2(alpha, 3 x their
  /// links) (if not, and three or more passed, the one with the highest leave-one-out index
  /// leaves and the rest are tested again); after its wait a cluster goes to the joint test with
  /// the other undecided ones. A group of agreeing false loops onto the robot's newest nodes,
  /// which hang from the map by odometry, fits wherever it points: a second revisit is what can
  /// contradict it. Default 100; 0: off (paper).
  int online_group_wait_nodes = 100;
  /// An online joint test that grows the good set is undone, and the clusters it added rejected,
  /// when the good set's chi2 (D2_G) rose by more than chi2(alpha, 3 x the links added): the
  /// joint test over every link absorbs the excess of one group that bends the map to fit
  /// (the far retry's increase test, online). Default true; false: off (paper).
  bool online_increase_test = true;
  /// A cluster of two links or more that an online joint test (or the revisit rule) would add to
  /// the good set is kept only if a decision from scratch of every closed cluster, made at that
  /// moment, keeps it too; otherwise the joint test is undone and it is rejected. The online
  /// decisions test a new group against the map they built, which their earlier decisions shaped;
  /// the decision from scratch weighs it against every closed cluster, with the robust ordering
  /// map and the leave-one-out check. One batch decision per group about to be accepted (a few
  /// tens in a run of thousands of nodes), under the online decisions' optimizer settings
  /// (incremental_relative_tolerance, incremental_factor_updates). A graph of one session only
  /// (several are decided from scratch every incremental_rebatch_every nodes). Default true; false:
  /// off (paper).
  bool online_scratch_check = true;
  /// Re-optimize the good set after this many clusters were accepted without it; default 32.
  int incremental_map_update_every = 32;
  /// In a graph of several sessions (parts no trusted constraint joins), when the robot passes
  /// a multiple of this many nodes, the closed clusters are decided from scratch, which places
  /// the sessions again; default 1000; 0: only at the end. A single session is decided online
  /// until the end (or the node's ~optimize): over part of one run, a decision from scratch
  /// accepted more false groups and reversed more true loops than the online decisions.
  int incremental_rebatch_every = 1000;
  /// Joint tests start from the good set's last factorization brought up to date by rank
  /// updates, instead of a fresh factorization each; default true.
  bool incremental_factor_updates = true;
  /// Joint tests stop when chi2 would drop by less than this fraction; default 1e-4.
  double incremental_relative_tolerance = 1e-4;

  /// Optimizer settings for every test; default Gauss-Newton.
  core::OptimizerParams optimizer;
};

/// Names accepted by applyPreset().
const std::vector<std::string>& presetNames();
/// "paper": the published algorithm (every addition off, one cluster removed per optimization,
/// every rejected cluster retried); "default": the defaults above. Leaves alpha, cluster_gap,
/// max_rounds and the optimizer as they are. Throws std::invalid_argument for another name.
void applyPreset(const std::string& name, RrrParams& params);

using core::outOfRangeMessage;
using core::ParamInfo;

/// Calls f(info, field) for every parameter of `p` (RrrParams or const RrrParams), field being a
/// double&, int& or bool& (const for const p), in a fixed order.
template <class Params, class F>
void forEachParam(Params& p, F&& f) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  f(ParamInfo{"alpha", 1e-6, 1.0 - 1e-9, "confidence of every chi-square test"}, p.alpha);
  f(ParamInfo{"cluster_gap", 0, 1e9, "nodes; 0 = derived from the candidates"}, p.cluster_gap);
  f(ParamInfo{"max_rounds", 1, 1e6, "realize/reverse/recover rounds per decision"}, p.max_rounds);
  f(ParamInfo{"reduced_intra_graph", 0, 1, "intra tests on the reduced graph"},
    p.reduced_intra_graph);
  f(ParamInfo{"intra_worst_link_removal", 0, 1,
              "a failing cluster loses its worst link and is tested again"},
    p.intra_worst_link_removal);
  f(ParamInfo{"split_mixed_clusters", 0, 1,
              "a failing cluster is split into pairwise consistent sets"},
    p.split_mixed_clusters);
  f(ParamInfo{"robust_ordering", 0, 1, "a robust (DCS) map orders the batch decision"},
    p.robust_ordering);
  f(ParamInfo{"dcs_phi", 1e-9, kInf, "DCS parameter of the robust ordering map"}, p.dcs_phi);
  f(ParamInfo{"warm_start", 0, 1, "joint tests start from the good map, not the initial estimate"},
    p.warm_start);
  f(ParamInfo{"reverse_good_clusters", 0, 1, "joint tests may remove good clusters (reverse)"},
    p.reverse_good_clusters);
  f(ParamInfo{"batch_removal_fraction", 0, 1,
              "inter-cluster removes clusters with index >= this x the worst (1: one at a time)"},
    p.batch_removal_fraction);
  f(ParamInfo{"conflict_removal", 0, 1,
              "when only the joint test fails, remove the cluster whose removal lowers chi2 most"},
    p.conflict_removal);
  f(ParamInfo{"settle_good_map", 0, 1, "the good set re-optimized from LAGO after realizing"},
    p.settle_good_map);
  f(
      ParamInfo{
          "recover_gate", 0, kInf,
          "recover retries rejected clusters whose index at the good map is below this (inf: all)"},
      p.recover_gate);
  f(ParamInfo{"far_retry_min_links", 0, 1e9,
              "rejected clusters of this many links far from the map are tried once (0: never)"},
    p.far_retry_min_links);
  f(ParamInfo{"leave_one_out_check", 0, 1,
              "reject good clusters whose removal lowers chi2 by more than their test"},
    p.leave_one_out_check);
  f(ParamInfo{"loo_min_index", 0, kInf,
              "the leave-one-out check examines clusters from this index"},
    p.loo_min_index);
  f(ParamInfo{"loo_joint_min_index", 0, 1,
              "clusters of this leave-one-out index and more are also left out together (0: off)"},
    p.loo_joint_min_index);
  f(ParamInfo{"joint_link_check", 0, 1, "drop links failing their test at the joint solution"},
    p.joint_link_check);
  f(ParamInfo{"place_sessions", 0, 1,
              "batch decisions start with each session placed by its largest joining cluster"},
    p.place_sessions);
  f(ParamInfo{"placement_min_ratio", 1, kInf,
              "a session is placed by a group of agreeing clusters only with this many times the "
              "clusters of a group that disagrees with it"},
    p.placement_min_ratio);
  f(ParamInfo{"placement_wider_reading", 0, 1,
              "of two groups that read differently where a session lies, the one seen over the "
              "longer stretch of it places it, not the one with more clusters"},
    p.placement_wider_reading);
  f(ParamInfo{"online_map_check", 0, 1,
              "incremental: clusters decided against the map before any joint test"},
    p.online_map_check);
  f(ParamInfo{"online_untestable_ratio", 0, kInf,
              "incremental: a one-link cluster the map must move to fit waits while the map's "
              "uncertainty of it exceeds this times its own (0: off)"},
    p.online_untestable_ratio);
  f(ParamInfo{"online_group_wait_nodes", 0, 1e9,
              "incremental: a cluster of several links between nodes more than N apart that the "
              "map cannot test waits up to N nodes for a second one that agrees with it (0: off)"},
    p.online_group_wait_nodes);
  f(ParamInfo{"online_increase_test", 0, 1,
              "incremental: a joint test whose added links raise the good set's chi2 beyond "
              "their own chi2 quantile is undone"},
    p.online_increase_test);
  f(ParamInfo{"online_scratch_check", 0, 1,
              "incremental: a group a joint test would add is kept only if a decision from "
              "scratch of the closed clusters keeps it too"},
    p.online_scratch_check);
  f(ParamInfo{"incremental_map_update_every", 1, 1e9,
              "incremental: re-optimize the map after this many accepted clusters"},
    p.incremental_map_update_every);
  f(ParamInfo{"incremental_rebatch_every", 0, 1e9,
              "incremental, several sessions: decide from scratch every N nodes (0: only at the "
              "end)"},
    p.incremental_rebatch_every);
  f(ParamInfo{"incremental_factor_updates", 0, 1,
              "incremental: joint tests update the good set's factor by rank updates"},
    p.incremental_factor_updates);
  f(ParamInfo{"incremental_relative_tolerance", 0, 1,
              "incremental: joint tests stop when chi2 drops by less than this fraction"},
    p.incremental_relative_tolerance);
}

/// Throws std::invalid_argument "NAME = VALUE is out of range: must be in [LOW, HIGH]" for the
/// first parameter out of its range (or NaN).
void validate(const RrrParams& params);

}  // namespace rrr_graphslam::rrr
