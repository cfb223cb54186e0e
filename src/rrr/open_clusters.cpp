#include "rrr_graphslam/rrr/open_clusters.h"

#include <algorithm>
#include <cstdlib>
#include <utility>

namespace rrr_graphslam::rrr {
namespace {

int newestEnd(const LoopCandidate& c) { return std::max(c.from, c.to); }
int oldestEnd(const LoopCandidate& c) { return std::min(c.from, c.to); }

}  // namespace

bool OpenClusters::add(int candidate) {
  const LoopCandidate& c = graph_.candidate(candidate);
  const OdometryChain& chain = graph_.chain();
  auto near = [&](int a, int b) { return std::abs(a - b) <= gap_ && chain.sameSession(a, b); };
  Cluster joined;
  joined.members.push_back(candidate);
  joined.newest = newestEnd(c);
  std::vector<Cluster> still_open;
  for (Cluster& open : open_) {
    const bool related = std::any_of(open.members.begin(), open.members.end(), [&](int m) {
      const LoopCandidate& o = graph_.candidate(m);
      return near(oldestEnd(o), oldestEnd(c)) && near(newestEnd(o), newestEnd(c));
    });
    if (related) {
      joined.members.insert(joined.members.end(), open.members.begin(), open.members.end());
      joined.newest = std::max(joined.newest, open.newest);
    } else {
      still_open.push_back(std::move(open));
    }
  }
  std::sort(joined.members.begin(), joined.members.end());
  const bool behind = current_node_ > joined.newest + gap_;
  still_open.push_back(std::move(joined));
  open_.swap(still_open);
  return behind;
}

std::vector<std::vector<int>> OpenClusters::advanceTo(int node) {
  current_node_ = std::max(current_node_, node);
  return closeIf([&](const Cluster& open) { return current_node_ > open.newest + gap_; });
}

std::vector<std::vector<int>> OpenClusters::closeAll() {
  return closeIf([](const Cluster&) { return true; });
}

std::vector<std::vector<int>> OpenClusters::closeJoining(int session_first) {
  const auto joins = [&](int m) {
    const LoopCandidate& c = graph_.candidate(m);
    return oldestEnd(c) < session_first && newestEnd(c) >= session_first;
  };
  return closeIf([&](const Cluster& open) {
    return std::any_of(open.members.begin(), open.members.end(), joins);
  });
}

std::vector<std::vector<int>> OpenClusters::closeIf(
    const std::function<bool(const Cluster&)>& closes) {
  std::vector<std::vector<int>> closed;
  std::vector<Cluster> still_open;
  for (Cluster& open : open_) {
    if (closes(open)) {
      closed.push_back(std::move(open.members));
    } else {
      still_open.push_back(std::move(open));
    }
  }
  open_.swap(still_open);
  return closed;
}

}  // namespace rrr_graphslam::rrr
