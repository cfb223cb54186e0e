#include "rrr_graphslam/frontend/online_trimmer.h"

#include <stdexcept>
#include <utility>

#include "rrr_graphslam/core/stopwatch.h"

namespace rrr_graphslam::frontend {
namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return 1e3 * core::secondsSince(start);
}

LaserSlam::Trimmed trim(const LaserSlam::Checkpoint& checkpoint, const TrimParams& params) {
  return LaserSlam::trimmed(checkpoint, params, OverlapRatioTrimming(params.trim_overlap_ratio));
}

}  // namespace

OnlineTrimmer::OnlineTrimmer(const OnlineTrimParams& params) : params_(params) {
  validate(params_.trim);
  if (params_.every_n_nodes < 0) throw std::invalid_argument("every_n_nodes must be >= 0");
  params_.trim.report_kl = false;  // an instrument of the benchmarks, not part of a trim
}

OnlineTrimmer::~OnlineTrimmer() { drop(); }

std::unique_ptr<LaserSlam> OnlineTrimmer::poll() {
  if (!pending_.valid() ||
      pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
    return nullptr;
  }
  return wait();
}

std::unique_ptr<LaserSlam> OnlineTrimmer::wait() {
  if (!pending_.valid()) return nullptr;
  LaserSlam::Trimmed trimmed;
  try {
    trimmed = pending_.get();
  } catch (...) {  // the running map stays; the trim never happened
    records_.pop_back();
    since_checkpoint_.clear();
    throw;
  }
  records_.back().trim_ms = msSince(started_);
  return finish(std::move(trimmed));
}

void OnlineTrimmer::drop() {
  if (!pending_.valid()) return;
  pending_.wait();
  pending_ = {};
  since_checkpoint_.clear();
  records_.pop_back();  // it replaced nothing
}

bool OnlineTrimmer::due(const LaserSlam& slam, std::optional<int> node) const {
  if (params_.every_n_nodes <= 0 || !node || slam.mode() != SessionMode::kMapping) return false;
  const int session_nodes = *node - slam.sessions().back().first_node + 1;
  return session_nodes > 0 && session_nodes % params_.every_n_nodes == 0 && slam.tied();
}

std::unique_ptr<LaserSlam> OnlineTrimmer::afterScan(LaserSlam& slam, const RangeScan& scan,
                                                    const core::Pose2& odom_pose,
                                                    std::optional<int> node) {
  ++scans_;
  if (pending_.valid()) {
    since_checkpoint_.push_back({scan, odom_pose});
    return poll();
  }
  if (!due(slam, node)) return nullptr;
  started_ = std::chrono::steady_clock::now();
  OnlineTrimRecord record;
  record.scan = scans_;
  record.nodes_before = slam.stats().nodes;
  LaserSlam::Checkpoint checkpoint = slam.checkpoint();
  record.checkpoint_ms = msSince(started_);
  records_.push_back(std::move(record));
  if (params_.in_line) {
    const auto start = std::chrono::steady_clock::now();
    LaserSlam::Trimmed trimmed;
    try {
      trimmed = trim(checkpoint, params_.trim);
    } catch (...) {
      records_.pop_back();
      throw;
    }
    records_.back().trim_ms = msSince(start);
    return finish(std::move(trimmed));
  }
  since_checkpoint_.clear();
  started_ = std::chrono::steady_clock::now();
  pending_ =
      std::async(std::launch::async, [checkpoint = std::move(checkpoint), params = params_.trim] {
        return trim(checkpoint, params);
      });
  return nullptr;
}

std::unique_ptr<LaserSlam> OnlineTrimmer::finish(LaserSlam::Trimmed trimmed) {
  OnlineTrimRecord& record = records_.back();
  record.report = std::move(trimmed.report);
  record.nodes_after = record.nodes_before;
  std::vector<Given> given = std::move(since_checkpoint_);
  since_checkpoint_.clear();
  if (!trimmed.slam) return nullptr;
  record.nodes_after = trimmed.slam->stats().nodes;
  const auto start = std::chrono::steady_clock::now();
  for (const Given& g : given) {
    try {
      trimmed.slam->addScan(g.scan, g.odom_pose);
    } catch (const ScanRefused&) {
      // Refused by the running map too, and reported then.
    } catch (const SensorMismatch&) {
    }
    ++record.replayed_scans;
  }
  record.replay_ms = msSince(start);
  return std::move(trimmed.slam);
}

}  // namespace rrr_graphslam::frontend
