#include "rrr_graphslam/frontend/online_trimmer.h"

#include <stdexcept>
#include <utility>

#include "rrr_graphslam/core/stopwatch.h"

namespace rrr_graphslam::frontend {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) { return 1e3 * core::secondsSince(start); }

}  // namespace

OnlineTrimmer::OnlineTrimmer(const OnlineTrimParams& params) : params_(params) {
  validate(params_.trim);
  if (params_.every_n_nodes < 0) throw std::invalid_argument("every_n_nodes must be >= 0");
  if (params_.every_n_nodes > 0 && params_.trim.sparsification == Sparsification::kDelete) {
    throw std::invalid_argument(
        "online trimming needs sparsification clt or dense: deletion would drop the running "
        "session's loops to the map with the trimmed nodes and could cut the session loose");
  }
  params_.trim.report_kl = false;  // an instrument of the benchmarks, not part of a trim
}

OnlineTrimmer::~OnlineTrimmer() { drop(); }

void OnlineTrimmer::drop() {
  if (!pending_.valid()) return;
  pending_.wait();
  pending_ = {};
  since_checkpoint_.clear();
}

bool OnlineTrimmer::due(const LaserSlam& slam) const {
  return params_.every_n_nodes > 0 && session_nodes_ % params_.every_n_nodes == 0 &&
         slam.trimsWhileMapping(params_.trim);
}

std::unique_ptr<LaserSlam> OnlineTrimmer::afterScan(LaserSlam& slam, const RangeScan& scan,
                                                    const core::Pose2& odom_pose,
                                                    std::optional<int> node) {
  ++scans_;
  if (node) ++session_nodes_;
  if (pending_.valid()) {
    since_checkpoint_.push_back({scan, odom_pose});
    return poll();
  }
  if (!node || !due(slam)) return nullptr;
  OnlineTrimRecord record;
  record.scan = scans_;
  record.nodes_before = slam.stats().nodes;
  const Clock::time_point start = Clock::now();
  LaserSlam::Checkpoint checkpoint = slam.checkpoint();
  record.checkpoint_ms = msSince(start);
  auto run = [params = params_.trim](const LaserSlam::Checkpoint& c) {
    const Clock::time_point watch = Clock::now();
    LaserSlam::Trimmed trimmed = LaserSlam::trimmed(c, params, *trimmingStrategy(params));
    return Outcome{std::move(trimmed), msSince(watch)};
  };
  if (params_.in_line) {
    in_flight_ = std::move(record);
    return finish(run(checkpoint));
  }
  pending_ = std::async(std::launch::async,
                        [run, checkpoint = std::move(checkpoint)] { return run(checkpoint); });
  in_flight_ = std::move(record);
  since_checkpoint_.clear();
  return nullptr;
}

std::unique_ptr<LaserSlam> OnlineTrimmer::poll() {
  if (!pending_.valid() ||
      pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
    return nullptr;
  }
  return wait();
}

std::unique_ptr<LaserSlam> OnlineTrimmer::wait() {
  if (!pending_.valid()) return nullptr;
  std::vector<Given> given = std::move(since_checkpoint_);
  since_checkpoint_.clear();
  Outcome outcome = pending_.get();  // rethrows what the trim threw: the running map stays
  std::unique_ptr<LaserSlam> slam = finish(std::move(outcome));
  if (!slam) return nullptr;
  const Clock::time_point start = Clock::now();
  try {
    for (const Given& g : given) {
      try {
        slam->addScan(g.scan, g.odom_pose);
      } catch (const ScanRefused&) {
        // Refused by the running map too, and reported then.
      } catch (const SensorMismatch&) {
      }
    }
  } catch (...) {  // the trimmed map is dropped: the running one stays
    --replaced_;
    throw;
  }
  last_.replayed_scans = static_cast<int>(given.size());
  last_.replay_ms = msSince(start);
  return slam;
}

std::unique_ptr<LaserSlam> OnlineTrimmer::finish(Outcome outcome) {
  last_ = std::move(in_flight_);
  last_.report = std::move(outcome.trimmed.report);
  last_.trim_ms = outcome.ms;
  last_.nodes_after =
      outcome.trimmed.slam ? outcome.trimmed.slam->stats().nodes : last_.nodes_before;
  ++finished_;
  if (outcome.trimmed.slam) ++replaced_;
  return std::move(outcome.trimmed.slam);
}

}  // namespace rrr_graphslam::frontend
