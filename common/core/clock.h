#pragma once
// Wall and monotonic clocks in SI units.

#include <chrono>
#include <cstdint>
#include <thread>

namespace nsim {

/// Wall-clock time since the Unix epoch (ns); comparable between processes on synchronized hosts.
inline int64_t WallTimeNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Monotonic time (s) from an arbitrary origin; for measuring durations and pacing loops.
inline double MonotonicSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Sleeps until the monotonic clock reads `t_mono` (s); returns at once if it is past.
inline void SleepUntilMonotonic(double t_mono) {
  const double dt = t_mono - MonotonicSeconds();
  if (dt > 0) std::this_thread::sleep_for(std::chrono::duration<double>(dt));
}

}  // namespace nsim
