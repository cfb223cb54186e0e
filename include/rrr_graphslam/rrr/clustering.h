#pragma once
// Grouping loop candidates into clusters of topologically related links (Latif et al., IJRR
// 2013, Sec. 4.1): two candidates are related when both their ends lie within `gap` nodes of each
// other's, in the same session (the last node of one session and the first of the next are
// consecutive ids, not neighbours). Clusters are the connected components of that relation
// (union-find), so the result does not depend on the order candidates are listed in, unlike a
// greedy index window.

#include <utility>
#include <vector>

namespace rrr_graphslam::rrr {

/// Ends of one candidate as dense node indices (any order).
using CandidateEnds = std::pair<int, int>;

/// Clusters as sorted lists of candidate indices, ordered by their first member. `session_of`
/// gives each node's session (empty: all nodes in one session).
std::vector<std::vector<int>> clusterCandidates(const std::vector<CandidateEnds>& ends, int gap,
                                                const std::vector<int>& session_of = {});

/// A gap from the data: 2.5x the 25th percentile of each candidate's Chebyshev distance to its
/// nearest neighbour in (low end, high end), clamped to [2, 50]. Loop closures found along a
/// revisited path sit a few nodes apart (1 in M3500, 5 in KITTI), which sets the percentile even
/// when outliers are as many as true loops.
int deriveClusterGap(const std::vector<CandidateEnds>& ends);

}  // namespace rrr_graphslam::rrr
