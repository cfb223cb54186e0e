#include "rrr_graphslam/rrr/session_placement.h"

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <utility>

#include "rrr_graphslam/core/chi2.h"
#include "rrr_graphslam/core/max_clique.h"

namespace rrr_graphslam::rrr {
namespace {

// The link's measurement from its map end to its session end, with its covariance.
struct Oriented {
  core::Pose2 z;
  Eigen::Matrix3d covariance;
};

Oriented oriented(const VerificationGraph& graph, const JoiningLink& link) {
  const LoopCandidate& c = graph.candidate(link.candidate);
  const Eigen::Matrix3d covariance = c.information.inverse();
  if (c.from == link.map_node) return {c.measurement, covariance};
  return {core::inverse(c.measurement), core::covarianceOfInverse(c.measurement, covariance)};
}

}  // namespace

core::Pose2 placingMotion(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
                          const JoiningLink& link) {
  const core::Pose2 target =
      core::compose(poses[static_cast<std::size_t>(link.map_node)], oriented(graph, link).z);
  return core::compose(target, core::inverse(poses[static_cast<std::size_t>(link.session_node)]));
}

double placementCycleChi2(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
                          const JoiningLink& a, const JoiningLink& b, bool map_exact) {
  // The later session end is predicted from the earlier one's link and the session's odometry,
  // and compared with where its own link puts it: the residual and the covariances in its frame.
  if (!graph.chain().sameSession(a.session_node, b.session_node)) {
    return std::numeric_limits<double>::infinity();  // no odometry between them to compare
  }
  const JoiningLink& first = a.session_node <= b.session_node ? a : b;
  const JoiningLink& second = a.session_node <= b.session_node ? b : a;
  const auto pose = [&](int node) -> const core::Pose2& {
    return poses[static_cast<std::size_t>(node)];
  };
  const Oriented l1 = oriented(graph, first);
  const Oriented l2 = oriented(graph, second);
  const core::Pose2 odometry = core::between(pose(first.session_node), pose(second.session_node));
  const core::Pose2 predicted = core::compose(core::compose(pose(first.map_node), l1.z), odometry);
  const core::Pose2 observed = core::compose(pose(second.map_node), l2.z);
  Eigen::Vector3d r = core::between(observed, predicted);
  r(2) = core::normalizeAngle(r(2));
  // l1's noise moves the prediction through the odometry; the odometry's own noise and l2's
  // are already in the second end's frame.
  const Eigen::Matrix3d to_second = core::adjoint(core::inverse(odometry));
  Eigen::Matrix3d covariance = to_second * l1.covariance * to_second.transpose() + l2.covariance;
  if (first.session_node != second.session_node) {
    covariance += graph.chain().relativeCovariance(first.session_node, second.session_node);
  }
  if (!map_exact && first.map_node != second.map_node &&
      graph.chain().sameSession(first.map_node, second.map_node)) {
    // The map's odometry noise between the map ends moves the second end's observed pose: the
    // covariance of the second map end in the first's frame, carried to the second session end.
    const Eigen::Matrix3d to_session = core::adjoint(core::inverse(l2.z));
    covariance += to_session * graph.chain().relativeCovariance(first.map_node, second.map_node) *
                  to_session.transpose();
  }
  return r.dot(covariance.ldlt().solve(r));
}

double spread(const VerificationGraph& graph, const std::vector<core::Pose2>& poses,
              const std::vector<int>& nodes) {
  if (nodes.size() < 2) return 0.0;
  const OdometryChain& chain = graph.chain();
  const bool one_chain = std::all_of(nodes.begin(), nodes.end(),
                                     [&](int n) { return chain.sameSession(n, nodes.front()); });
  if (one_chain) {
    const auto [low, high] = std::minmax_element(nodes.begin(), nodes.end(), [&](int a, int b) {
      return chain.travel(a) < chain.travel(b);
    });
    return chain.travel(*high) - chain.travel(*low);
  }
  double farthest = 0.0;
  for (int p : nodes) {
    for (int q : nodes) {
      farthest = std::max(farthest, (poses[static_cast<std::size_t>(p)].head<2>() -
                                     poses[static_cast<std::size_t>(q)].head<2>())
                                        .norm());
    }
  }
  return farthest;
}

PlacementGroup largestAgreeingGroup(const VerificationGraph& graph,
                                    const std::vector<core::Pose2>& poses,
                                    const std::vector<JoiningLink>& links, double alpha,
                                    bool map_exact, bool with_rival) {
  const int n = static_cast<int>(links.size());
  const double threshold = core::chi2Quantile(alpha, 3);
  core::AdjacencyMatrix agree(n);
  for (int p = 0; p < n; ++p) {
    for (int q = p + 1; q < n; ++q) {
      if (placementCycleChi2(graph, poses, links[static_cast<std::size_t>(p)],
                             links[static_cast<std::size_t>(q)], map_exact) < threshold) {
        agree.connect(p, q);
      }
    }
  }
  PlacementGroup group;
  group.members = core::maximumClique(agree);
  std::vector<int> ends;
  for (int p : group.members) ends.push_back(links[static_cast<std::size_t>(p)].session_node);
  group.spread_m = spread(graph, poses, ends);
  if (!with_rival) return group;
  std::vector<int> disagreeing;
  for (int p = 0; p < n; ++p) {
    if (std::none_of(group.members.begin(), group.members.end(),
                     [&](int q) { return p == q || agree.connected(p, q); })) {
      disagreeing.push_back(p);
    }
  }
  if (!disagreeing.empty()) group.rival = core::maximumClique(agree, disagreeing);
  return group;
}

void preferWiderReading(PlacementGroup& group,
                        const std::function<double(const std::vector<int>&)>& stretch_of) {
  group.spread_m = stretch_of(group.members);
  if (group.rival.size() < 2 ||
      static_cast<double>(group.rival.size()) <
          kWiderReadingMinShare * static_cast<double>(group.members.size())) {
    return;
  }
  const double rival = stretch_of(group.rival);
  if (rival <= group.spread_m) return;
  std::swap(group.members, group.rival);
  group.spread_m = rival;
}

bool outnumbersRival(const PlacementGroup& group, double min_ratio) {
  return min_ratio <= 1.0 || group.rival.empty() ||
         static_cast<double>(group.members.size()) >=
             min_ratio * static_cast<double>(group.rival.size());
}

}  // namespace rrr_graphslam::rrr
