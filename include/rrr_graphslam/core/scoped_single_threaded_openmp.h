#pragma once
// While in scope, OpenMP parallel regions run inactive (one thread). The core is built with
// OpenMP (for CHOLMOD, see sparse_solver.cpp), which also makes Eigen split large dense products
// and factorizations over all cores. On a loaded 2-core computer the threads' wake-ups cost far
// more than they save: chowLiuTree over a 102-node blanket took 93 ms with Eigen's threads while
// two other processes kept both cores busy, 11 ms on one thread. Only for the core's own .cpp
// files (they are compiled with OpenMP); not thread-safe against other code changing the same
// OpenMP setting. sparse_solver.cpp holds one around its CHOLMOD calls.

#include <omp.h>

namespace rrr_graphslam::core {

class ScopedSingleThreadedOpenMp {
 public:
  ScopedSingleThreadedOpenMp() : saved_levels_(omp_get_max_active_levels()) {
    omp_set_max_active_levels(0);
  }
  ~ScopedSingleThreadedOpenMp() { omp_set_max_active_levels(saved_levels_); }
  ScopedSingleThreadedOpenMp(const ScopedSingleThreadedOpenMp&) = delete;
  ScopedSingleThreadedOpenMp& operator=(const ScopedSingleThreadedOpenMp&) = delete;

 private:
  int saved_levels_;
};

}  // namespace rrr_graphslam::core
