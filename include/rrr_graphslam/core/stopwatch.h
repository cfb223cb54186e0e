#pragma once
// Elapsed time on the steady clock, for timings that tools and statistics report.

#include <chrono>

namespace rrr_graphslam::core {

using Clock = std::chrono::steady_clock;

/// Seconds from `start` until now.
inline double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Seconds from `since` until now; `since` becomes now (consecutive laps of one clock).
inline double lap(Clock::time_point& since) {
  const Clock::time_point now = Clock::now();
  const double sec = std::chrono::duration<double>(now - since).count();
  since = now;
  return sec;
}

}  // namespace rrr_graphslam::core
