#pragma once
// Fork-join over a fixed number of parts on persistent threads: Run(fn) calls fn(0) on the
// calling thread and fn(1) .. fn(parts - 1) on helper threads started once, and returns when
// every part is done. The work of each part is fixed by the caller (not scheduled), so a
// computation split this way gives the same bits on every run whatever the threads' timing.
// Used by FemSolver for its element passes (FemConfig::element_threads).

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace nsim {

class ForkJoin {
 public:
  /// parts >= 1; parts - 1 helper threads.
  explicit ForkJoin(int parts);
  ~ForkJoin();
  ForkJoin(const ForkJoin&) = delete;
  ForkJoin& operator=(const ForkJoin&) = delete;

  int parts() const { return parts_; }
  /// fn(p) for every part p, part 0 on this thread; returns when all have returned. Not
  /// reentrant; fn must not throw.
  void Run(const std::function<void(int)>& fn);

 private:
  void HelperLoop(int part);

  const int parts_;
  std::vector<std::thread> helpers_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  const std::function<void(int)>* job_ = nullptr;  // under mutex_
  std::uint64_t generation_ = 0;                    // under mutex_: bumped by each Run
  int running_ = 0;                                 // under mutex_: helpers still working
  bool quit_ = false;                               // under mutex_
};

}  // namespace nsim
