#include "common/core/sequence_tracker.h"

namespace nsim {

SequenceTracker::Verdict SequenceTracker::Observe(uint64_t seq) {
  const bool first = received_ == 0;
  ++received_;
  if (first || seq > newest_) {
    for (uint64_t s = first ? 0 : newest_ + 1; s < seq; ++s) missing_.insert(s);
    missing_.erase(seq);  // declared missing by EndAt, arrived after all
    newest_ = seq;
    return Verdict::kNext;
  }
  ++out_of_order_;
  if (missing_.erase(seq) == 0) ++duplicates_;
  return Verdict::kLate;
}

void SequenceTracker::EndAt(uint64_t last_seq) {
  const uint64_t first_unseen = received_ == 0 ? 0 : newest_ + 1;
  for (uint64_t s = first_unseen; s <= last_seq; ++s) missing_.insert(s);
}

}  // namespace nsim
