#pragma once
// Scheduling classes of this program's threads (Linux).
//
// On one CPU, the liver's factor refresh (a background thread, common/fem/fem_solver.cpp) and
// the realtime loop's steps take turns on the core. The kernel's fair scheduler (EEVDF since
// Linux 6.6) gives even a nice-19 or SCHED_IDLE thread its share in whole timer ticks: measured
// with scene_bench's paced sequence on one core (taskset -c 1, Linux 6.18, HZ 250), a step
// that ran while a refresh was in flight lost exactly 4.0 ms to it (one involuntary context
// switch, the thread's CPU time unchanged) in about half of the runs. A loop thread in the
// realtime class (SCHED_FIFO) is never preempted by a fair-class thread: the refresh then gets
// only the time the loop leaves between its steps.

#include <string>

namespace nsim {

/// Puts the calling thread in the lowest class (SCHED_IDLE: it runs only when no other thread
/// of the CPU wants to), falling back to nice 19; returns false if neither could be set.
bool LowerThisThreadToIdle();

/// Puts the calling thread in the normal class (SCHED_OTHER, priority 0): out of SCHED_FIFO /
/// SCHED_RR, which is always permitted, and a no-op for a thread already there. Returns false
/// if the kernel refused (leaving SCHED_IDLE needs CAP_SYS_NICE or an RLIMIT_NICE of 20).
bool MoveThisThreadToNormalClass();

/// Puts the calling thread in SCHED_FIFO at `priority` (1-99). Needs CAP_SYS_NICE or an
/// RLIMIT_RTPRIO of at least `priority` (`ulimit -r`, limits.conf `rtprio`). Returns an empty
/// string on success, else why not (the thread's class is then unchanged). Threads the
/// calling thread starts afterwards inherit the class; start them first.
std::string RaiseThisThreadToFifo(int priority);

/// SCHED_FIFO at `priority` for the calling thread while in scope (RaiseThisThreadToFifo), then
/// the normal class again (SCHED_OTHER, nice 0). priority 0: nothing is changed.
class FifoScope {
 public:
  explicit FifoScope(int priority);
  ~FifoScope();
  FifoScope(const FifoScope&) = delete;
  FifoScope& operator=(const FifoScope&) = delete;
  /// Why the class could not be raised (empty: raised, or priority 0).
  const std::string& error() const { return error_; }
  bool raised() const { return raised_; }

 private:
  std::string error_;
  bool raised_ = false;
};

/// The calling thread's class: "fifo", "rr", "idle", "batch", "other" (else "policy N").
std::string ThisThreadPolicyName();

}  // namespace nsim
