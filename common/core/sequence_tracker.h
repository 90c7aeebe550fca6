#pragma once
// Bookkeeping of a numbered stream: which sequence numbers arrived, which never did (gaps),
// and which came late (out of order or duplicated).

#include <cstdint>
#include <set>

namespace nsim {

/// Tracks the sequence numbers of one stream whose first sample is numbered 0.
class SequenceTracker {
 public:
  /// What one observed sequence number was.
  enum class Verdict {
    kNext,  ///< newer than every earlier one (skipped numbers are counted missing)
    kLate,  ///< not newer than the newest seen: out of order (filling a gap) or a duplicate
  };

  /// Records `seq`. Samples with kLate should not be treated as the newest state.
  Verdict Observe(uint64_t seq);

  /// Declares that the stream's last sample was `last_seq`; numbers after the newest seen up to
  /// it count as missing. Later observations are still counted.
  void EndAt(uint64_t last_seq);

  uint64_t received() const { return received_; }          ///< every observation
  uint64_t missing() const { return missing_.size(); }     ///< numbers never observed
  uint64_t out_of_order() const { return out_of_order_; }  ///< late arrivals (incl. duplicates)
  uint64_t duplicates() const { return duplicates_; }      ///< late arrivals seen before
  bool any() const { return received_ > 0; }
  uint64_t newest() const { return newest_; }  ///< meaningful when any()

 private:
  uint64_t received_ = 0, out_of_order_ = 0, duplicates_ = 0, newest_ = 0;
  std::set<uint64_t> missing_;
};

}  // namespace nsim
