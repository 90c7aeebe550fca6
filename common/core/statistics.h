#pragma once
// Sample statistics shared by both processes' summaries: median, percentiles, and a running
// timing accumulator. One definition each (README "Outputs").

#include <cstdint>
#include <vector>

namespace nsim {

/// Median of the values (the mean of the two middle ones for an even count); 0 when empty.
double Median(std::vector<double> values);

/// The q-quantile (0 <= q <= 1) by linear interpolation between order statistics (the
/// "type 7" definition of Hyndman & Fan, as numpy's default): q = 0.5 equals Median. 0 when
/// empty.
double Percentile(std::vector<double> values, double q);

/// Summary of a series of samples (units of the samples).
struct SampleSummary {
  uint64_t count = 0;
  double mean = 0.0, median = 0.0, p90 = 0.0, p95 = 0.0, p99 = 0.0, max = 0.0;
};
/// Summarizes `values` (all zero when empty).
SampleSummary Summarize(const std::vector<double>& values);

/// Running mean and maximum of a duration (s), without keeping the samples.
struct TimingStat {
  double sum = 0.0, max = 0.0;
  uint64_t count = 0;
  void Add(double seconds);
  double mean() const { return count ? sum / static_cast<double>(count) : 0.0; }
  /// Events per second of a period statistic (count / sum); 0 when empty.
  double rate() const { return sum > 0 ? static_cast<double>(count) / sum : 0.0; }
};

}  // namespace nsim
