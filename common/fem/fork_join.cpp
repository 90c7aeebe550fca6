#include "common/fem/fork_join.h"

#include "common/core/error.h"

namespace nsim {

ForkJoin::ForkJoin(int parts) : parts_(parts) {
  NSIM_CHECK(parts >= 1, "ForkJoin needs at least one part, got ", parts);
  for (int p = 1; p < parts_; ++p) helpers_.emplace_back([this, p] { HelperLoop(p); });
}

ForkJoin::~ForkJoin() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  start_.notify_all();
  for (std::thread& t : helpers_) t.join();
}

void ForkJoin::Run(const std::function<void(int)>& fn) {
  if (parts_ == 1) {
    fn(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = &fn;
    running_ = parts_ - 1;
    ++generation_;
  }
  start_.notify_all();
  fn(0);
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return running_ == 0; });
  job_ = nullptr;
}

void ForkJoin::HelperLoop(int part) {
  std::uint64_t seen = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    start_.wait(lock, [&] { return quit_ || generation_ != seen; });
    if (quit_) return;
    seen = generation_;
    const std::function<void(int)>* job = job_;
    lock.unlock();
    (*job)(part);
    lock.lock();
    if (--running_ == 0) done_.notify_one();
  }
}

}  // namespace nsim
