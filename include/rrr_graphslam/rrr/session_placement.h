#pragma once
// Placing a session in the map (multi-session RRR). A cluster that joins a session no good
// cluster ties to the map yet closes no cycle: no test of RRR can tell a true relocalization
// from an aliased one (a corridor like another, a room like the next), and the first such cluster
// accepted would decide every later one against itself. So a session is placed only by a group
// of its joining clusters that agree with one another on where it lies and that it saw from
// places at least `min_spread` apart: one place can be mistaken, a stretch of path rarely is.
//
// Two joining clusters agree when the cycle through their first links closes: the map between
// their map ends taken as the good set's map has it, the session's odometry between their session
// ends with its covariance (pairwise_consistency.h does the same within one session). The group
// is a maximum clique of agreeing clusters (core::maximumClique).

#include <functional>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

/// A candidate joining `session` to the rest, oriented from its map end to its session end.
struct JoiningLink {
  int candidate;
  int map_node;
  int session_node;
};

/// The rigid motion that takes the session, at `poses`, to where `link` puts its session end
/// (its map end where `poses` has it): compose it onto every node of the session.
core::Pose2 placingMotion(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
                          const JoiningLink& link);

/// Chi-square (3 dof) of the cycle through two links joining the same session to the map, at
/// `poses`: the session side's relative pose from `poses`, its covariance from the odometry chain
/// (infinite, no agreement, if the chain does not hold both session ends); the map side's
/// relative pose from `poses` too, exact when `map_exact` (poses of the good map, which loops
/// made), otherwise with the covariance of the map's own odometry between its two ends (poses
/// that odometry made; ends in different chains are then taken as exact).
double placementCycleChi2(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
                          const JoiningLink& a, const JoiningLink& b, bool map_exact = true);

/// How far apart the nodes of one session are: the path length between the first and the last
/// of them along the session's odometry (as the front end counts a session's travel), or where
/// they lie in different odometry chains (a trimmed session joined by marginal constraints), the
/// largest distance between two of them at `poses`. 0 for fewer than two.
double spread(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
              const std::vector<int>& nodes);

struct PlacementGroup {
  std::vector<int> members;  ///< indices into the links given, sorted
  double spread_m = 0.0;     ///< spread() of the given links' session ends
  /// With `with_rival`: the largest group among the links that agree with no member, another
  /// reading of where the session lies (the building seen from its other end, the next
  /// corridor), sorted. A link that agrees with one member is not a rival's, nor counted against
  /// the group; links whose session ends lie on another odometry chain than a member's (a
  /// trimmed session) cannot be compared and count as disagreeing.
  std::vector<int> rival;
};

/// The largest group of mutually agreeing links (cycle chi2 below chi2(alpha, 3)), how far
/// apart the session saw them and, if asked, its rival; links[k] stands for the k-th cluster.
PlacementGroup largestAgreeingGroup(const VerificationGraph& graph,
                                    const std::vector<core::Pose2>& poses,
                                    const std::vector<JoiningLink>& links, double alpha,
                                    bool map_exact = true, bool with_rival = false);

/// Of the largest group and its rival (computed with `with_rival`), the reading that places the
/// session: the rival instead when the session saw it over a longer stretch, by
/// `stretch_of(members)` (m; e.g. spread() over every kept link's session end), and it has two or
/// more clusters and at least kWiderReadingMinShare of the largest group's. A place seen alike
/// from two poses (a building turned by 180 degrees, the next of two alike corridors) fits only as
/// far as the likeness goes; the true reading fits wherever the session meets the map. Clusters
/// count the same reading unevenly (the front end's whole-map search before a tie rests after a
/// few matches and makes small clusters; its search around a tied reading makes long ones), the
/// stretch does not. The two are swapped in `group` (members and rival) and spread_m set to the
/// placing one's stretch. After a swap the group has fewer clusters than its rival, so a
/// placement_min_ratio above 1 holds the session until the other outnumbers it again.
void preferWiderReading(PlacementGroup& group,
                        const std::function<double(const std::vector<int>&)>& stretch_of);
inline constexpr double kWiderReadingMinShare = 0.5;

/// Whether the group has at least `min_ratio` times its rival's clusters. A place seen the same
/// from two poses gives two groups that each agree with themselves and grow side by side while
/// the robot drives where both readings fit: the session is tied only once one of them clearly
/// has more support (the ratio test of place recognition, applied to groups). True for
/// min_ratio <= 1 and for a group without a rival.
bool outnumbersRival(const PlacementGroup& group, double min_ratio);

}  // namespace rrr_graphslam::rrr
