#include "common/core/statistics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace nsim {

double Median(std::vector<double> values) { return Percentile(std::move(values), 0.5); }

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(values.size() - 1, below + 1);
  const double fraction = position - static_cast<double>(below);
  return values[below] + fraction * (values[above] - values[below]);
}

SampleSummary Summarize(const std::vector<double>& values) {
  SampleSummary s;
  if (values.empty()) return s;
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  s.count = sorted.size();
  s.mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / static_cast<double>(s.count);
  s.median = Percentile(sorted, 0.5);
  s.p90 = Percentile(sorted, 0.90);
  s.p95 = Percentile(sorted, 0.95);
  s.p99 = Percentile(sorted, 0.99);
  s.max = sorted.back();
  return s;
}

void TimingStat::Add(double seconds) {
  sum += seconds;
  max = std::max(max, seconds);
  ++count;
}

}  // namespace nsim
