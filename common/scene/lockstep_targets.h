#pragma once
// The targets a lockstep patient loop applies (DESIGN.md "Time, modes and determinism"): with a
// simulated latency of d steps, step k applies the newest target answering a frame at most
// k - d, and waits (the caller's job) until the controller has answered frame k - d or a newer
// one. The same rule runs in the DDS pump and in the in-process loop, so both give the same
// run to the last digit.

#include <cstdint>
#include <map>
#include <optional>

#include "common/core/samples.h"

namespace nsim {

class LockstepTargets {
 public:
  /// latency_steps >= 0 (InputError otherwise).
  explicit LockstepTargets(int latency_steps);

  /// A target received from the controller (a later one for the same frame replaces it).
  void Add(const RobotTarget& target);
  /// True when step k need not wait: k < d, or a target answering frame k - d or newer is here.
  bool Ready(int64_t k) const;
  /// The target step k applies: the newest answering a frame <= k - d (and drops it and the
  /// older ones); none when k < d or no such target arrived (the robot keeps its command).
  std::optional<RobotTarget> TakeFor(int64_t k);

  /// Drops every target received (another controller took over).
  void Clear() { pending_.clear(); }

  int latency_steps() const { return latency_steps_; }
  size_t pending() const { return pending_.size(); }

 private:
  int latency_steps_;
  std::map<uint64_t, RobotTarget> pending_;  // by answers_seq
};

}  // namespace nsim
