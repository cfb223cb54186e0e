#pragma once
// Where a decision's time goes, step by step: each named step of RRR (Algorithm 1's intra test,
// the robust ordering map, realize, recover, the far retry, ...) with its calls, its own wall
// time (a step's time excludes the steps it calls), the optimizations it ran and the numeric
// factorizations it made: how many, their time, and their size as CHOLMOD's flop count.
// `rrr_offline --profile` prints it.

#include <chrono>
#include <string>
#include <vector>

#include "rrr_graphslam/core/sparse_solver.h"

namespace rrr_graphslam::rrr {

struct StepCost {
  std::string step;
  int calls = 0;
  double seconds = 0.0;  ///< wall time in the step itself, its nested steps apart
  int optimizations = 0;
  int factorizations = 0;
  double factorization_seconds = 0.0;
  double factorization_flops = 0.0;  ///< summed: their mean says how large they were
};

class StepProfile {
 public:
  /// What the profiled code has done so far, read at every step boundary.
  struct Counters {
    int optimizations = 0;
    core::FactorizationWork factorizations;
  };

  /// `step` starts; the enclosing one pauses until it ends. Steps nest (each leave() ends the
  /// innermost).
  void enter(const char* step, const Counters& now);
  void leave(const Counters& now);

  /// One entry per step, in the order first entered.
  const std::vector<StepCost>& steps() const { return steps_; }

 private:
  struct Open {
    std::size_t step;
    std::chrono::steady_clock::time_point since;
    Counters at;
  };
  // Charges the innermost open step with what was done since it (re)started.
  void chargeInnermost(std::chrono::steady_clock::time_point now, const Counters& counters);
  std::size_t stepIndex(const char* step);

  std::vector<StepCost> steps_;
  std::vector<Open> open_;
};

/// A table of `steps` with their share of `total_seconds`, one line per step, for a terminal.
std::string formatStepProfile(const std::vector<StepCost>& steps, double total_seconds);

}  // namespace rrr_graphslam::rrr
