#include "common/core/sequence_tracker.h"

#include <gtest/gtest.h>

namespace nsim {
namespace {

TEST(SequenceTracker, InOrderStreamHasNoGaps) {
  SequenceTracker t;
  for (uint64_t s = 0; s < 10; ++s) EXPECT_EQ(t.Observe(s), SequenceTracker::Verdict::kNext);
  t.EndAt(9);
  EXPECT_EQ(t.received(), 10u);
  EXPECT_EQ(t.missing(), 0u);
  EXPECT_EQ(t.out_of_order(), 0u);
}

TEST(SequenceTracker, CountsGapsLateArrivalsAndDuplicates) {
  SequenceTracker t;
  t.Observe(1);  // 0 missing
  t.Observe(4);  // 2, 3 missing
  EXPECT_EQ(t.missing(), 3u);
  EXPECT_EQ(t.Observe(3), SequenceTracker::Verdict::kLate);  // fills a gap
  EXPECT_EQ(t.missing(), 2u);
  EXPECT_EQ(t.Observe(4), SequenceTracker::Verdict::kLate);  // duplicate
  EXPECT_EQ(t.out_of_order(), 2u);
  EXPECT_EQ(t.duplicates(), 1u);
  EXPECT_EQ(t.newest(), 4u);
}

TEST(SequenceTracker, TailLossCountsAtTheEnd) {
  SequenceTracker t;
  t.Observe(0);
  t.Observe(1);
  t.EndAt(5);  // 2..5 never came
  EXPECT_EQ(t.missing(), 4u);
  t.Observe(5);  // arrives after the end was declared
  EXPECT_EQ(t.missing(), 3u);
}

TEST(SequenceTracker, EmptyStreamEndingAtZeroMissesOne) {
  SequenceTracker t;
  t.EndAt(0);
  EXPECT_EQ(t.missing(), 1u);
  EXPECT_FALSE(t.any());
}

}  // namespace
}  // namespace nsim
