// placement_min_spread_m: a session joins the map through a group of clusters that agree on where
// it lies and that it saw from places apart (session_placement.h), never through one alone.

#include <algorithm>
#include <cstdio>
#include <map>

#include "rrr_graphslam/rrr/rrr.h"
#include "rrr_graphslam/rrr/session_placement.h"

namespace rrr_graphslam::rrr {
namespace {

std::string metres(double m) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f m", m);
  return text;
}

// Why the ratio test held a group back, for the reason of the clusters that wait.
std::string rivalNote(const PlacementGroup& group, double min_ratio) {
  if (outnumbersRival(group, min_ratio)) return "";
  char text[128];
  std::snprintf(text, sizeof(text),
                "; a rival group of %zu clusters agrees with none of them (%g times as many "
                "needed)",
                group.rival.size(), min_ratio);
  return text;
}

}  // namespace

std::vector<std::size_t> Rrr::joinedSessions() const {
  return graph_.componentsJoinedBy(acceptedCandidates());
}

std::vector<int> Rrr::takePlacingClusters(std::vector<int>& pending) {
  // The sessions good clusters tie to the first node's make the map.
  const std::vector<std::size_t> joined = joinedSessions();
  auto joined_of = [&](int node) { return joined[static_cast<std::size_t>(node)]; };
  const std::size_t map = joined.empty() ? 0 : joined.front();
  auto in_map = [&](int node) { return joined_of(node) == map; };

  // Per untied session, its clusters joining it to the map (first kept link, oriented). A
  // cluster a joint test rejected while its session was untied (the session in its own frame)
  // stays a candidate for a group.
  std::vector<int> candidates = pending;
  for (int c : clustersWith(Status::kRejected)) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    if (kept.empty()) continue;
    const LoopCandidate& link = graph_.candidate(kept.front());
    if (in_map(link.from) != in_map(link.to)) candidates.push_back(c);
  }
  std::map<std::size_t, std::vector<std::pair<int, JoiningLink>>> joining;
  std::vector<int> rest;
  for (int c : candidates) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    if (kept.empty()) {
      rest.push_back(c);
      continue;
    }
    const LoopCandidate& link = graph_.candidate(kept.front());
    const bool from_in = in_map(link.from);
    const bool to_in = in_map(link.to);
    // Within the map, or within one untied session (its own loops): decided as any other.
    if (joined_of(link.from) == joined_of(link.to)) {
      rest.push_back(c);
      continue;
    }
    if (from_in != to_in) {
      const JoiningLink oriented = from_in ? JoiningLink{kept.front(), link.from, link.to}
                                           : JoiningLink{kept.front(), link.to, link.from};
      joining[joined_of(oriented.session_node)].push_back({c, oriented});
      continue;
    }
    // Between two sessions neither of which is placed: it waits for them.
    setStatus(c, Status::kUnplaced, "placement: joins two sessions not yet tied to the map");
  }
  pending.swap(rest);

  std::vector<int> groups;
  for (const auto& [untied, clusters] : joining) {
    std::vector<JoiningLink> links;
    for (const auto& [c, link] : clusters) links.push_back(link);
    const auto stretch = [&](const std::vector<int>& members) {
      std::vector<int> of_members;
      for (int k : members) of_members.push_back(clusters[static_cast<std::size_t>(k)].first);
      return keptLinksSpread(of_members, base_, [&](int node) { return !in_map(node); });
    };
    PlacementGroup group = placingGroup(base_, links, true, stretch);
    const bool placed = groupPlaces(group, group.spread_m);
    if (placed) {
      // The joint test starts with the session moved rigidly onto the group's largest cluster's
      // first link (as placeSessions does): its own frame says nothing of where it lies.
      std::size_t largest = static_cast<std::size_t>(group.members.front());
      for (int k : group.members) {
        const auto size = [&](std::size_t i) {
          return kept_links_[static_cast<std::size_t>(clusters[i].first)].size();
        };
        if (size(static_cast<std::size_t>(k)) > size(largest))
          largest = static_cast<std::size_t>(k);
      }
      const core::Pose2 motion = placingMotion(graph_, base_, clusters[largest].second);
      for (int n = 0; n < graph_.numNodes(); ++n) {
        if (joined_of(n) == untied) {
          base_[static_cast<std::size_t>(n)] =
              core::compose(motion, base_[static_cast<std::size_t>(n)]);
        }
      }
    }
    for (std::size_t k = 0; k < clusters.size(); ++k) {
      const int c = clusters[k].first;
      if (placed &&
          std::binary_search(group.members.begin(), group.members.end(), static_cast<int>(k))) {
        setStatus(c, Status::kPending, "");
        groups.push_back(c);
        continue;
      }
      setStatus(c, Status::kUnplaced,
                "placement: its session is not tied to the map; the largest group of agreeing "
                "clusters joining them has " +
                    std::to_string(group.members.size()) + " of " +
                    std::to_string(clusters.size()) + ", seen " + metres(group.spread_m) +
                    " apart (" + metres(params_.placement_min_spread_m) + " needed)" +
                    rivalNote(group, params_.placement_min_ratio));
    }
  }
  return groups;
}

double Rrr::keptLinksSpread(const std::vector<int>& clusters, const std::vector<core::Pose2>& poses,
                            const std::function<bool(int)>& in_session) const {
  std::vector<int> ends;
  for (int c : clusters) {
    for (int link : kept_links_[static_cast<std::size_t>(c)]) {
      const LoopCandidate& l = graph_.candidate(link);
      ends.push_back(in_session(l.from) ? l.from : l.to);
    }
  }
  return spread(graph_, poses, ends);
}

PlacementGroup Rrr::placingGroup(
    const std::vector<core::Pose2>& poses, const std::vector<JoiningLink>& links, bool map_exact,
    const std::function<double(const std::vector<int>&)>& stretch) const {
  PlacementGroup group =
      largestAgreeingGroup(graph_, poses, links, params_.alpha, map_exact,
                           params_.placement_min_ratio > 1.0 || params_.placement_wider_reading);
  if (params_.placement_wider_reading) {
    preferWiderReading(group, stretch);
  } else {
    group.spread_m = stretch(group.members);
  }
  return group;
}

bool Rrr::groupPlaces(const PlacementGroup& group, double spread_m) const {
  return group.members.size() >= 2 && spread_m >= params_.placement_min_spread_m &&
         outnumbersRival(group, params_.placement_min_ratio);
}

bool Rrr::holdLoosePlacements() {
  bool held_any = false;
  for (bool held = true; held;) {
    held = false;
    const std::vector<int> session = graph_.trustedComponents();
    // Per session, the good clusters with one end in it, and those ends.
    std::map<int, std::vector<int>> clusters_of, ends_of;
    for (int c : clustersWith(Status::kGood)) {
      const auto& kept = kept_links_[static_cast<std::size_t>(c)];
      for (int k : kept) {
        const LoopCandidate& link = graph_.candidate(k);
        const int a = session[static_cast<std::size_t>(link.from)];
        const int b = session[static_cast<std::size_t>(link.to)];
        if (a == b) continue;
        ends_of[a].push_back(link.from);
        ends_of[b].push_back(link.to);
        if (clusters_of[a].empty() || clusters_of[a].back() != c) clusters_of[a].push_back(c);
        if (clusters_of[b].empty() || clusters_of[b].back() != c) clusters_of[b].push_back(c);
      }
    }
    for (const auto& [s, clusters] : clusters_of) {
      if (s == session[0]) continue;  // the map's own first session is where the others go
      const double seen = spread(graph_, base_, ends_of[s]);
      if (clusters.size() >= 2 && seen >= params_.placement_min_spread_m) continue;
      for (int c : clusters) {
        setStatus(c, Status::kUnplaced,
                  "placement: the " + std::to_string(clusters.size()) +
                      " good clusters joining its session to the others were seen " + metres(seen) +
                      " apart (two or more, " + metres(params_.placement_min_spread_m) +
                      " apart, needed)");
      }
      held = held_any = true;
      break;  // the sessions' ties changed: look again
    }
  }
  return held_any;
}

void Rrr::holdUnplacedSessions(const std::vector<char>& placed_sessions) {
  const std::vector<int> session = graph_.trustedComponents();
  auto placed = [&](int node) {
    return placed_sessions[static_cast<std::size_t>(session[static_cast<std::size_t>(node)])] != 0;
  };
  for (int c : clustersWith(Status::kPending)) {
    const auto& kept = kept_links_[static_cast<std::size_t>(c)];
    const LoopCandidate& link = graph_.candidate(kept.front());
    const bool own =
        session[static_cast<std::size_t>(link.from)] == session[static_cast<std::size_t>(link.to)];
    if (own || (placed(link.from) && placed(link.to))) continue;
    setStatus(c, Status::kUnplaced,
              "placement: no group of agreeing clusters seen " +
                  metres(params_.placement_min_spread_m) + " apart places its session in the map");
  }
}

void Rrr::rejectUnplaced() {
  for (int c : clustersWith(Status::kUnplaced)) {
    setStatus(c, Status::kRejected, clusters_[static_cast<std::size_t>(c)].reason);
  }
}

}  // namespace rrr_graphslam::rrr
