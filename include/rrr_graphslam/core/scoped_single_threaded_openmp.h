#pragma once
// While in scope, OpenMP parallel regions run inactive (one thread): sparse_solver.cpp holds one
// around its CHOLMOD calls (see there why). Only for the core's own .cpp files (they are compiled
// with OpenMP); not thread-safe against other code changing the same OpenMP setting. Eigen's own
// products never start threads in this product: EIGEN_DONT_PARALLELIZE (CMakeLists.txt).

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
