#include "common/scene/lockstep_targets.h"

#include <iterator>

#include "common/core/error.h"

namespace nsim {

LockstepTargets::LockstepTargets(int latency_steps) : latency_steps_(latency_steps) {
  if (latency_steps < 0)
    throw InputError(Str("run.latency_steps must be >= 0, got ", latency_steps));
}

void LockstepTargets::Add(const RobotTarget& target) { pending_[target.answers_seq] = target; }

bool LockstepTargets::Ready(int64_t k) const {
  const int64_t need = k - latency_steps_;
  if (need < 0) return true;
  return !pending_.empty() && pending_.rbegin()->first >= static_cast<uint64_t>(need);
}

std::optional<RobotTarget> LockstepTargets::TakeFor(int64_t k) {
  const int64_t need = k - latency_steps_;
  if (need < 0) return std::nullopt;
  auto end = pending_.upper_bound(static_cast<uint64_t>(need));  // first answering > k - d
  if (end == pending_.begin()) return std::nullopt;
  std::optional<RobotTarget> newest = std::prev(end)->second;
  pending_.erase(pending_.begin(), end);
  return newest;
}

}  // namespace nsim
