#include "rrr_graphslam/rrr/step_profile.h"

#include <cstdio>

namespace rrr_graphslam::rrr {

std::size_t StepProfile::stepIndex(const char* step) {
  for (std::size_t i = 0; i < steps_.size(); ++i) {
    if (steps_[i].step == step) return i;
  }
  steps_.push_back(StepCost{step});
  return steps_.size() - 1;
}

void StepProfile::chargeInnermost(std::chrono::steady_clock::time_point now,
                                  const Counters& counters) {
  if (open_.empty()) return;
  Open& open = open_.back();
  StepCost& cost = steps_[open.step];
  cost.seconds += std::chrono::duration<double>(now - open.since).count();
  cost.optimizations += counters.optimizations - open.at.optimizations;
  const core::FactorizationWork& before = open.at.factorizations;
  const core::FactorizationWork& after = counters.factorizations;
  cost.factorizations += after.factorizations - before.factorizations;
  cost.factorization_seconds += after.seconds - before.seconds;
  cost.factorization_flops += after.flops - before.flops;
  open.since = now;
  open.at = counters;
}

void StepProfile::enter(const char* step, const Counters& now) {
  const auto clock = std::chrono::steady_clock::now();
  chargeInnermost(clock, now);
  const std::size_t index = stepIndex(step);
  ++steps_[index].calls;
  open_.push_back(Open{index, clock, now});
}

void StepProfile::leave(const Counters& now) {
  if (open_.empty()) return;
  const auto clock = std::chrono::steady_clock::now();
  chargeInnermost(clock, now);
  open_.pop_back();
  if (!open_.empty()) {
    open_.back().since = clock;
    open_.back().at = now;
  }
}

std::string formatStepProfile(const std::vector<StepCost>& steps, double total_seconds) {
  std::string out;
  char line[256];
  double inside = 0.0;
  std::snprintf(line, sizeof line, "%-34s %6s %9s %6s %13s %8s %9s %11s\n", "step", "calls",
                "time (s)", "share", "optimizations", "factors", "time (s)", "mean flops");
  out += line;
  for (const StepCost& s : steps) {
    const double share = total_seconds > 0.0 ? 100.0 * s.seconds / total_seconds : 0.0;
    const double mean_flops = s.factorizations > 0 ? s.factorization_flops / s.factorizations : 0.0;
    std::snprintf(line, sizeof line, "%-34s %6d %9.3f %5.1f%% %13d %8d %9.3f %11.3g\n",
                  s.step.c_str(), s.calls, s.seconds, share, s.optimizations, s.factorizations,
                  s.factorization_seconds, mean_flops);
    out += line;
    inside += s.seconds;
  }
  // Clustering, bookkeeping, and with incremental runs the replay itself.
  std::snprintf(line, sizeof line, "%-34s %6s %9.3f %5.1f%%\n", "(outside the steps)", "",
                total_seconds - inside,
                total_seconds > 0.0 ? 100.0 * (total_seconds - inside) / total_seconds : 0.0);
  out += line;
  return out;
}

}  // namespace rrr_graphslam::rrr
