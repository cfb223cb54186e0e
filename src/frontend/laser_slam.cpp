#include "rrr_graphslam/frontend/laser_slam.h"
#include "rrr_graphslam/frontend/plausible_pose.h"
#include "rrr_graphslam/frontend/rival_reading.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include <mrpt/poses/CPose3D.h>

#include "rrr_graphslam/core/stopwatch.h"

namespace rrr_graphslam::frontend {

using core::secondsSince;

namespace {

// RRR ties a session to the map as the front end counts it tied: by loops this far apart.
LaserSlamParams withPlacementSpread(LaserSlamParams params) {
  params.rrr.rrr.placement_min_spread_m = params.loops.relocalization_confirm_distance_m;
  return params;
}

}  // namespace

LaserSlam::LaserSlam(const LaserSlamParams& params, const std::string& session_name)
    : params_(withPlacementSpread(params)),
      local_(params.local),
      rrr_(std::make_unique<rrr::OnlineRrr>(params_.rrr)),
      sessions_{{session_name, 0.0, 0}} {
  if (!(params.odometry_stddev.array() > 0.0).all()) {
    throw std::invalid_argument("odometry_stddev must be positive");
  }
  if (params.loops.search_every_n_nodes < 1 || params.loops.threads < 1 ||
      params.loops.pause_after_match_nodes < 0) {
    throw std::invalid_argument(
        "search_every_n_nodes and threads must be at least 1, pause_after_match_nodes at least 0");
  }
  odometry_information_ = params.odometry_stddev.cwiseAbs2().cwiseInverse().asDiagonal();
}

std::optional<int> LaserSlam::addScan(const RangeScan& scan, const core::Pose2& odom_pose) {
  // The sensor setup is checked once, on the session's first scan with a plausible laser pose
  // (an implausible one is local SLAM's to refuse): a converter that interpolates the laser pose
  // may vary the mounting from scan to scan, which must not stop a run half-way.
  if (map_sensor_ && plausibleLaserPose(scan.laser_in_robot)) {
    const SensorSetup setup = SensorSetup::of(scan);
    if (!setup.sameAs(*map_sensor_)) {
      throw SensorMismatch("the scan's laser has " + setup.describe() + "; the map's scans have " +
                           map_sensor_->describe() +
                           ": a map made with another sensor setup cannot be continued");
    }
    map_sensor_.reset();
  }
  adoptCandidatesFromOutside();
  auto start = std::chrono::steady_clock::now();
  LocalSlamResult result;
  try {
    result = local_.addScan(scan, odom_pose);
  } catch (const ScanRefused&) {
    ++stats_.refused_scans;
    throw;
  }
  stats_.local_slam_seconds += secondsSince(start);
  ++stats_.scans;
  stats_.matched_scans += result.matched ? 1 : 0;
  stats_.velocity_predicted_scans += result.velocity_predicted ? 1 : 0;

  if (result.node) {
    const int node = *result.node;
    start = std::chrono::steady_clock::now();
    if (node == sessions_.back().first_node) {
      sessions_.back().start_time = scan.timestamp;
      rrr_->startSession(static_cast<rrr::OnlineRrr::NodeId>(node), result.local_pose);
    } else {
      rrr_->addOdometry(node - 1, node, core::between(node_local_poses_.back(), result.local_pose),
                        odometry_information_);
    }
    stats_.rrr_seconds += secondsSince(start);
    node_travel_.push_back(
        node == sessions_.back().first_node
            ? 0.0
            : node_travel_.back() +
                  (result.local_pose.head<2>() - node_local_poses_.back().head<2>()).norm());
    node_local_poses_.push_back(result.local_pose);
    node_timestamps_.push_back(scan.timestamp);
    // Localization keeps no scan of its own: the map stays the loaded one.
    node_scans_.push_back(mode_ == SessionMode::kLocalization
                              ? nullptr
                              : std::make_shared<const mrpt::obs::CObservation2DRangeScan>(
                                    std::move(*result.observation)));
    stats_.nodes = node + 1;
    stats_.submaps = local_.submaps().numSubmaps();
    if (result.finished_submap && mode_ == SessionMode::kMapping) {
      finished_.push_back(result.finished_submap);
      finished_spans_.push_back(
          {result.finished_submap->anchorNode(), result.finished_submap->lastNode()});
      search_state_.resize(static_cast<std::size_t>(result.finished_submap->index()) + 1);
      ++stats_.finished_submaps;
    }
    keepSessionPoints(node, result.points);
    searchLoops(node, result.points);
    // A session of a loaded map trims its own nodes only once it is tied: the count is exact.
    if (!tie_ && sessions_.size() > 1 && tied()) {
      tie_ = Tie{node, node - sessions_.back().first_node, scan.timestamp};
    }
  }
  const int newest = static_cast<int>(node_local_poses_.size()) - 1;
  scan_timestamps_.push_back(scan.timestamp);
  scan_node_.push_back(newest);
  scan_offset_.push_back(
      core::between(node_local_poses_[static_cast<std::size_t>(newest)], result.local_pose));
  return result.node;
}

void LaserSlam::searchLoops(int node, const PointCloud& scan_points) {
  const auto& p = params_.loops;
  PointCloud points;
  for (const auto& q : scan_points) {
    if (q.norm() <= p.max_point_range_m) points.push_back(q);
  }
  if (finished_.empty() || points.size() < 10) return;
  const std::vector<core::Pose2> map = rrr_->mapPoses();
  const core::Pose2& node_pose = map[static_cast<std::size_t>(node)];
  // While this session is not tied to the earlier ones, their submaps are searched whole
  // (relocalization); around its map pose too once accepted loops place it.
  const bool relocalizing = sessions_.size() > 1 && !tied();
  const bool placed_now = relocalizing && placed();
  // After a few matches to the map, the earlier sessions' submaps rest (below), also when those
  // matches tied the session: no candidate joining the session to the map comes within the gap.
  const bool resting = sessions_.size() > 1 && node < relocalization_paused_until_;
  const bool on_schedule =
      (node - sessions_.back().first_node) % p.relocalization_every_n_nodes == 0;
  const bool relocalize_now = relocalizing && !resting && on_schedule;
  // With two earlier sessions or more, some may lie in parts of the map (mapParts) this session
  // is not joined to: once it is tied, those are searched whole on the same schedule, with rests
  // apart from the relocalization's (one for all such parts), and never around a map pose (their
  // frames are unrelated to this session's).
  // (Not needed on the nodes of a relocalization that search no earlier session.)
  const bool searches_earlier = !relocalizing || placed_now || relocalize_now;
  const std::vector<std::size_t> part =
      sessions_.size() > 2 && searches_earlier ? mapParts() : std::vector<std::size_t>{};
  const auto part_of = [&](const Submap& submap) {
    return part.empty() ? 0 : part[static_cast<std::size_t>(submap.anchorNode())];
  };
  // Not in this node's part: the map's once the session is placed or tied.
  const auto apart = [&](const Submap& submap) {
    return !part.empty() && part_of(submap) != part[static_cast<std::size_t>(node)];
  };
  const bool join_now = !relocalizing && on_schedule && node >= apart_paused_until_;

  // Which submaps to search, and from where (in node order, so the result does not depend on
  // the threads).
  struct Search {
    const Submap* submap;
    core::Pose2 initial;
    bool whole = false;
    std::optional<LoopMatch> loop{};
    double seconds = 0.0;
    bool rival = false;      // around the rival reading of where the session lies
    bool apart = false;      // whole, in a part of the map this session is not joined to
    bool ambiguous = false;  // a distinct pose scored nearly as well: not proposed
  };
  std::vector<Search> searches;
  // With a hint, where it puts this node in the map.
  std::optional<core::Pose2> hinted;
  if (hint_) {
    const int hint_node = hint_->node >= 0 ? hint_->node : sessions_.back().first_node;
    hinted = core::compose(hint_->map_pose,
                           core::between(node_local_poses_[static_cast<std::size_t>(hint_node)],
                                         node_local_poses_[static_cast<std::size_t>(node)]));
  }
  // A search of `submap` around where `pose` (a map pose) puts this node, if the submap's anchor
  // lies within reach of it.
  const auto around = [&](const Submap& submap, const core::Pose2& pose,
                          bool rival) -> std::optional<Search> {
    const core::Pose2& anchor = map[static_cast<std::size_t>(submap.anchorNode())];
    if ((anchor.head<2>() - pose.head<2>()).norm() > p.max_constraint_distance_m) {
      return std::nullopt;
    }
    Search s{&submap, core::compose(submap.anchorPose(), core::between(anchor, pose)), false};
    s.rival = rival;
    return s;
  };
  // Cartographer's per-submap sampling, and a pause after a match: the next few nodes would tell
  // RRR the same thing about this submap.
  const auto due = [&](SubmapSearchState& state) {
    if (node - state.last_searched < p.search_every_n_nodes) return false;
    if (node - state.last_matched < p.pause_after_match_nodes) return false;
    state.last_searched = node;
    return true;
  };
  for (const auto& submap : finished_) {
    const bool earlier_session = submap->index() < session_first_submap_;
    if (earlier_session && resting) continue;
    if (relocalizing && earlier_session && relocalize_now) {
      if (!hinted) {
        searches.push_back({submap.get(), core::Pose2::Zero(), true});
      } else if (auto s = around(*submap, *hinted, false)) {
        searches.push_back(*s);
      }
      continue;
    }
    if (relocalizing && earlier_session && !placed_now) continue;
    if (earlier_session && apart(*submap)) {
      if (join_now) {
        Search s{submap.get(), core::Pose2::Zero(), true};
        s.apart = true;
        searches.push_back(s);
      }
      continue;
    }
    if (node - submap->lastNode() < p.min_node_separation) continue;
    auto s = around(*submap, node_pose, false);
    if (s && due(search_state_[static_cast<std::size_t>(submap->index())])) {
      searches.push_back(*s);
    }
  }
  // Once tied, the rival reading too (rivalReading): the earlier sessions' submaps near where it
  // puts this node, with their own sampling and pauses.
  std::optional<core::Pose2> rival;
  // Not once trimming folded the tie into marginal constraints: RRR cannot place it anew.
  if (sessions_.size() > 1 && !relocalizing && !tied_by_marginals_ && p.rival_min_loops > 0) {
    rival = rivalReading(node, map, part);
  }
  if (rival && !resting) {
    rival_search_state_.resize(search_state_.size());
    for (const auto& submap : finished_) {
      if (submap->index() >= session_first_submap_ || apart(*submap)) continue;
      auto s = around(*submap, *rival, true);
      if (s && due(rival_search_state_[static_cast<std::size_t>(submap->index())])) {
        searches.push_back(*s);
      }
    }
  }
  if (searches.empty()) return;
  const auto start = std::chrono::steady_clock::now();
  const LoopSearchScan scan = loopSearchScan(std::move(points), p);  // thinned once per node
  const int n = static_cast<int>(searches.size());
#pragma omp parallel for schedule(dynamic) num_threads(p.threads) if (p.threads > 1 && n > 1)
  for (int k = 0; k < n; ++k) {
    Search& s = searches[static_cast<std::size_t>(k)];
    const auto match_start = std::chrono::steady_clock::now();
    SubmapSearch found = s.whole ? matchNodeToWholeSubmap(*s.submap, node, scan, p)
                                 : matchNodeToSubmap(*s.submap, node, scan, s.initial, p);
    s.loop = std::move(found.loop);
    s.ambiguous = found.alias.has_value();
    s.seconds = secondsSince(match_start);
  }
  stats_.loop_search_seconds += secondsSince(start);
  for (const Search& s : searches) {
    stats_.loop_search_pair_seconds += s.seconds;
    (s.whole ? stats_.relocalization_searches : stats_.loop_searches) += 1;
    stats_.rival_searches += s.rival ? 1 : 0;
    stats_.ambiguous_matches += s.ambiguous ? 1 : 0;
  }
  bool relocalized = false;
  bool joined_apart = false;
  // The earlier sessions' submaps of each part, placed once, for the first match to check.
  std::map<std::size_t, std::vector<PlacedSubmap>> earlier_submaps;
  for (const Search& s : searches) {
    if (!s.loop) continue;
    const bool to_earlier_session = relocalizing && s.submap->index() < session_first_submap_;
    if ((to_earlier_session || s.rival || s.apart) && p.relocalization_max_conflict < 1.0) {
      // The match places the session in the frame of the part it matched: it is checked against
      // the free space of that part's submaps.
      std::vector<PlacedSubmap>& placed = earlier_submaps[part_of(*s.submap)];
      if (placed.empty()) {
        for (const auto& submap : finished_) {
          if (submap->index() >= session_first_submap_ || part_of(*submap) != part_of(*s.submap))
            continue;
          placed.push_back(
              placeSubmap(*submap, map[static_cast<std::size_t>(submap->anchorNode())]));
        }
      }
      const MapAgreement agreement = sessionAgreement(*s.loop, map, placed);
      if (agreement.contradicts(p.agreement, p.relocalization_max_conflict)) {
        ++stats_.contradicted_matches;
        continue;
      }
    }
    (s.rival ? rival_search_state_ : search_state_)[static_cast<std::size_t>(s.submap->index())]
        .last_matched = node;
    addCandidate(s.loop->from, s.loop->to, s.loop->measurement, s.loop->information,
                 s.whole   ? LoopSource::kWholeMapSearch
                 : s.rival ? LoopSource::kRivalSearch
                           : LoopSource::kLocalSearch);
    relocalized = relocalized || to_earlier_session;
    joined_apart = joined_apart || s.apart;
  }
  // After a few nodes matched the map its search rests for longer than cluster_gap, so that the
  // next matches, farther along, make a cluster of their own that can confirm or contradict
  // these. Nothing can join their clusters then, so RRR decides them now (places the session, or
  // rejects them and the search goes on) rather than once the robot is cluster_gap nodes past
  // them: the same clusters, decided sooner.
  if (relocalized && ++relocalization_matches_ >= p.relocalization_matches) {
    relocalization_matches_ = 0;
    relocalization_paused_until_ = node + params_.rrr.rrr.cluster_gap + 1;
    rrr_->closeJoining(static_cast<rrr::OnlineRrr::NodeId>(sessions_.back().first_node));
  }
  // The same rhythm for the parts not joined, so that their matches make clusters along the
  // session that RRR can place the part by (decided when the gap closes them).
  if (joined_apart && ++apart_matches_ >= p.relocalization_matches) {
    apart_matches_ = 0;
    apart_paused_until_ = node + params_.rrr.rrr.cluster_gap + 1;
  }
}

void LaserSlam::keepSessionPoints(int node, const PointCloud& points) {
  const LoopSearchParams& p = params_.loops;
  if (sessions_.size() < 2 || p.relocalization_max_conflict >= 1.0 ||
      (tied() && p.rival_min_loops == 0 && sessions_.size() < 3)) {
    session_points_.clear();
    return;
  }
  // A few dozen points a node: the check is about where walls are, not about matching.
  constexpr std::size_t kPointsPerNode = 48;
  const std::size_t step =
      std::max<std::size_t>(1, (points.size() + kPointsPerNode - 1) / kPointsPerNode);
  KeptPoints kept{node, {}};
  for (std::size_t i = 0; i < points.size(); i += step) kept.points.push_back(points[i]);
  session_points_.push_back(std::move(kept));
  const double travel = node_travel_[static_cast<std::size_t>(node)];
  while (travel - node_travel_[static_cast<std::size_t>(session_points_.front().node)] >
         p.relocalization_check_travel_m) {
    session_points_.pop_front();
  }
}

MapAgreement LaserSlam::sessionAgreement(const LoopMatch& loop,
                                         const std::vector<core::Pose2>& poses,
                                         const std::vector<PlacedSubmap>& map) const {
  // Where the match puts the node, and with it the session's earlier nodes (the session's own
  // estimate of its path).
  const core::Pose2 placed =
      core::compose(poses[static_cast<std::size_t>(loop.from)], loop.measurement);
  const core::Pose2& node_pose = poses[static_cast<std::size_t>(loop.to)];
  std::vector<Eigen::Vector2d> points;
  for (const KeptPoints& kept : session_points_) {
    const core::Pose2 pose =
        core::compose(placed, core::between(node_pose, poses[static_cast<std::size_t>(kept.node)]));
    const Eigen::Matrix2d rotation = core::rotation(pose.z());
    for (const Eigen::Vector2d& q : kept.points) points.push_back(rotation * q + pose.head<2>());
  }
  return mapAgreement(map, points, params_.loops.agreement);
}

std::optional<core::Pose2> LaserSlam::rivalReading(int node, const std::vector<core::Pose2>& map,
                                                   const std::vector<std::size_t>& part) const {
  const auto at = [&](int n) -> const core::Pose2& { return map[static_cast<std::size_t>(n)]; };
  const core::Pose2& here = at(node);
  const ReadingAgreement within;
  // The search window is a square (in the submap's frame): its corners reach sqrt(2) times out.
  const ReadingAgreement searched{std::sqrt(2.0) * params_.loops.window.linear_m,
                                  params_.loops.window.angular_rad};
  std::vector<SessionReading> readings;
  std::size_t tied_loops = 0;
  for (const Crossing& c : crossing_) {
    if (rrr_->verdict(c.candidate) == rrr::Verdict::kAccepted) {
      ++tied_loops;
      continue;
    }
    const rrr::LoopCandidate& l = rrr_->candidate(c.candidate);
    const int earlier = l.to == c.session_node ? l.from : l.to;
    // A loop to a part of the map not joined to it reads the session in that part's frame.
    if (!part.empty() &&
        part[static_cast<std::size_t>(earlier)] != part[static_cast<std::size_t>(node)]) {
      continue;
    }
    const core::Pose2 placed = l.to == c.session_node
                                   ? core::compose(at(l.from), l.measurement)
                                   : core::compose(at(l.to), core::inverse(l.measurement));
    const core::Pose2 pose = core::compose(placed, core::between(at(c.session_node), here));
    // Readings within the search window around where the map has the node are the accepted
    // reading's search's to find.
    if (!readingsAgree(pose, here, searched)) readings.push_back({pose, c.session_node});
  }
  const auto group =
      largestReading(readings, static_cast<std::size_t>(params_.loops.rival_min_loops), within);
  // A reading with a small share of the tied one's loops is a local likeness (a room like the
  // next), not a rival the session could be placed by: searching it would only feed RRR loops to
  // reject.
  constexpr double kRivalMinShareOfTied = 0.25;
  if (!group ||
      static_cast<double>(group->size) < kRivalMinShareOfTied * static_cast<double>(tied_loops)) {
    return std::nullopt;
  }
  return group->pose;
}

void LaserSlam::noteCrossing(int candidate) {
  const int first = sessions_.back().first_node;
  const rrr::LoopCandidate& c = rrr_->candidate(candidate);  // dense node indices
  if (std::min(c.from, c.to) < first && std::max(c.from, c.to) >= first) {
    crossing_.push_back({candidate, std::max(c.from, c.to)});
  }
}

std::vector<std::size_t> LaserSlam::mapParts() const {
  std::vector<int> accepted;
  for (int k = 0; k < rrr_->numCandidates(); ++k) {
    if (rrr_->verdict(k) == rrr::Verdict::kAccepted) accepted.push_back(k);
  }
  return rrr_->verificationGraph().componentsJoinedBy(accepted);
}

LoopSource LaserSlam::candidateSource(int candidate) const {
  if (candidate < 0 || candidate >= rrr_->numCandidates()) {
    throw std::out_of_range("candidate " + std::to_string(candidate) + " is not one of RRR's " +
                            std::to_string(rrr_->numCandidates()));
  }
  const auto k = static_cast<std::size_t>(candidate);
  return k < candidate_source_.size() ? candidate_source_[k] : LoopSource::kExternal;
}

void LaserSlam::adoptCandidatesFromOutside() {
  for (int k = static_cast<int>(candidate_source_.size()); k < rrr_->numCandidates(); ++k) {
    candidate_source_.push_back(LoopSource::kExternal);
    noteCrossing(k);
  }
}

bool LaserSlam::addCandidate(int from, int to, const core::Pose2& measurement,
                             const Eigen::Matrix3d& information, LoopSource source) {
  adoptCandidatesFromOutside();
  const auto rrr_start = std::chrono::steady_clock::now();
  const int index = rrr_->numCandidates();
  const int nodes = rrr_->numNodes();
  if (from < 0 || to < 0 || from >= nodes || to >= nodes) {  // RRR would wait for them
    ++stats_.refused_candidates;
    return false;
  }
  try {
    rrr_->addCandidate(static_cast<rrr::OnlineRrr::NodeId>(from),
                       static_cast<rrr::OnlineRrr::NodeId>(to), measurement, information);
  } catch (const std::invalid_argument&) {
    // One RRR cannot take (information not positive definite, a duplicate): no candidate.
    ++stats_.refused_candidates;
    return false;
  }
  if (rrr_->numCandidates() > index) {
    candidate_source_.push_back(source);
    noteCrossing(index);
  }
  stats_.rrr_seconds += secondsSince(rrr_start);
  ++stats_.candidates;
  return true;
}

void LaserSlam::setInitialPose(const core::Pose2& map_pose) {
  if (sessions_.size() < 2) {
    throw std::logic_error("an initial pose needs a loaded map to be placed in");
  }
  const int newest = static_cast<int>(node_local_poses_.size()) - 1;
  hint_ = Hint{newest >= sessions_.back().first_node ? newest : -1, map_pose};
}

double LaserSlam::acceptedCrossingSpread() const {
  double nearest = std::numeric_limits<double>::infinity();
  double farthest = -nearest;
  for (const Crossing& c : crossing_) {
    if (rrr_->verdict(c.candidate) != rrr::Verdict::kAccepted) continue;
    const double travel = node_travel_[static_cast<std::size_t>(c.session_node)];
    nearest = std::min(nearest, travel);
    farthest = std::max(farthest, travel);
  }
  return farthest - nearest;  // -inf without any
}

bool LaserSlam::tied() const {
  return tied_by_marginals_ ||
         acceptedCrossingSpread() >= params_.loops.relocalization_confirm_distance_m;
}

bool LaserSlam::placed() const { return acceptedCrossingSpread() >= 0.0; }

void LaserSlam::finish() {
  adoptCandidatesFromOutside();
  const auto start = std::chrono::steady_clock::now();
  rrr_->finish();
  stats_.rrr_seconds += secondsSince(start);
}

std::vector<core::Pose2> LaserSlam::scanMapPoses() const {
  const std::vector<core::Pose2> map = rrr_->mapPoses();
  std::vector<core::Pose2> poses;
  poses.reserve(scan_node_.size());
  for (std::size_t k = 0; k < scan_node_.size(); ++k) {
    poses.push_back(core::compose(map[static_cast<std::size_t>(scan_node_[k])], scan_offset_[k]));
  }
  return poses;
}

MapInputs LaserSlam::mapInputs() const {
  MapInputs inputs;
  inputs.poses = rrr_->mapPoses();
  inputs.scans = node_scans_;
  inputs.insertion = params_.local.submap;
  inputs.sessions.reserve(node_scans_.size());
  for (std::size_t s = 0; s < sessions_.size(); ++s) {
    const auto end = s + 1 < sessions_.size()
                         ? static_cast<std::size_t>(sessions_[s + 1].first_node)
                         : node_scans_.size();
    inputs.sessions.resize(std::max(inputs.sessions.size(), std::min(end, node_scans_.size())),
                           sessions_[s].number);
  }
  inputs.memory = memory_;
  if (mode_ == SessionMode::kLocalization) {  // the loaded map alone
    const auto loaded = static_cast<std::size_t>(sessions_.back().first_node);
    inputs.poses.resize(loaded);
    inputs.scans.resize(loaded);
    inputs.sessions.resize(loaded);
  }
  return inputs;
}

}  // namespace rrr_graphslam::frontend
