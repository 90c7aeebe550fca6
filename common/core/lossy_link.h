#pragma once
// A lossy link for lockstep runs: each message is lost with a fixed probability, drawn from a
// seeded generator of its own, so that a run with loss is reproducible to the last digit. It
// stands for a network that loses packets under reliable keep-last-1 streams (the sensor frames
// and the robot targets, messages/transport.h): a lost sample is not retransmitted once a newer
// one is written, so its reader skips it.

#include <cstdint>
#include <random>

namespace nsim {

class LossyLink {
 public:
  /// percent in [0, 100] (InputError "<name> must be in [0, 100] (percent), got ..."); `stream`
  /// separates the links of one run (frames, targets) drawn from the same seed.
  LossyLink(double percent, uint64_t seed, uint64_t stream, const char* name = "--loss");

  /// InputError "<name> must be in [0, 100] (percent), got ..." unless percent is in [0, 100].
  static void CheckPercent(double percent, const char* name);

  /// True when the next message is lost (counted).
  bool Drop();

  uint64_t sent() const { return sent_; }  ///< messages offered to the link
  uint64_t lost() const { return lost_; }  ///< of them, lost

 private:
  double probability_;
  std::mt19937_64 rng_;
  uint64_t sent_ = 0, lost_ = 0;
};

}  // namespace nsim
