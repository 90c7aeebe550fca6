// Median, Percentile (type 7 quantiles) and the timing accumulator against values computed by
// hand and against an independent definition (the order statistic for q = i / (n - 1)).
#include "common/core/statistics.h"

#include <gtest/gtest.h>

#include <random>

namespace nsim {
namespace {

TEST(StatisticsTest, MedianOfOddAndEvenCounts) {
  EXPECT_DOUBLE_EQ(Median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_DOUBLE_EQ(Median({}), 0.0);
  EXPECT_DOUBLE_EQ(Median({7.0}), 7.0);
}

TEST(StatisticsTest, PercentileInterpolatesBetweenOrderStatistics) {
  // 1..5: q = 0.9 is at position 3.6 -> 4 + 0.6 (numpy.percentile(.., 90) = 4.6)
  const std::vector<double> v = {5, 1, 4, 2, 3};
  EXPECT_DOUBLE_EQ(Percentile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(Percentile(v, 1.0), 5.0);
  EXPECT_NEAR(Percentile(v, 0.9), 4.6, 1e-12);
  EXPECT_NEAR(Percentile(v, 0.25), 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(Percentile(v, 0.5), Median(v));
}

TEST(StatisticsTest, PercentileAtGridPointsIsTheOrderStatistic) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> v(101);
  for (double& x : v) x = u(rng);
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i)
    // i / 100 is not exact in binary: the position is i to within 1e-14
    EXPECT_NEAR(Percentile(v, static_cast<double>(i) / 100.0), sorted[i], 1e-12) << i;
}

TEST(StatisticsTest, SummarizeAgreesWithTheSingleFunctions) {
  std::vector<double> v;
  for (int i = 1; i <= 200; ++i) v.push_back(i * 0.5);
  const SampleSummary s = Summarize(v);
  EXPECT_EQ(s.count, 200u);
  EXPECT_DOUBLE_EQ(s.mean, 0.5 * 100.5);
  EXPECT_DOUBLE_EQ(s.median, Median(v));
  EXPECT_DOUBLE_EQ(s.p99, Percentile(v, 0.99));
  EXPECT_DOUBLE_EQ(s.max, 100.0);
  EXPECT_EQ(Summarize({}).count, 0u);
}

TEST(StatisticsTest, TimingStatMeanMaxAndRate) {
  TimingStat t;
  EXPECT_EQ(t.mean(), 0.0);
  EXPECT_EQ(t.rate(), 0.0);
  t.Add(0.02);
  t.Add(0.04);
  EXPECT_DOUBLE_EQ(t.mean(), 0.03);
  EXPECT_DOUBLE_EQ(t.max, 0.04);
  EXPECT_DOUBLE_EQ(t.rate(), 2.0 / 0.06);
}

}  // namespace
}  // namespace nsim
