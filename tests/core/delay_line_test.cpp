#include "common/core/delay_line.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace nsim {
namespace {

TEST(DelayLine, ReleasesNothingBeforeItsDueTime) {
  DelayLine<int> line;
  line.Push(1.0, 7);
  std::vector<int> out;
  line.Release(0.999, [&](int v) { out.push_back(v); });
  EXPECT_TRUE(out.empty());
  EXPECT_DOUBLE_EQ(line.TimeToNext(0.75), 0.25);
  line.Release(1.0, [&](int v) { out.push_back(v); });  // due exactly now
  EXPECT_EQ(out, std::vector<int>{7});
  EXPECT_TRUE(line.empty());
}

TEST(DelayLine, ReleasesEveryDueItemOldestFirstAndKeepsTheRest) {
  DelayLine<int> line;
  for (int i = 0; i < 5; ++i) line.Push(0.1 * i + 0.04, i);  // a 40 ms delay, one item a step
  std::vector<int> out;
  line.Release(0.25, [&](int v) { out.push_back(v); });
  EXPECT_EQ(out, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(line.size(), 2u);
  EXPECT_NEAR(line.TimeToNext(0.25), 0.09, 1e-12);
}

TEST(DelayLine, AnOverdueItemIsDueNowAndAnEmptyLineNever) {
  DelayLine<int> line;
  EXPECT_TRUE(std::isinf(line.TimeToNext(0.0)));
  line.Push(1.0, 1);
  EXPECT_EQ(line.TimeToNext(2.0), 0.0);  // never negative: a wait of it polls
}

}  // namespace
}  // namespace nsim
