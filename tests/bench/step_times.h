#pragma once
// Step-time distribution of a sequence benchmark: each benchmark iteration is one simulation
// step, timed on the wall clock; the counters give the distribution of one repetition (one
// sequence): p50_ms, p90_ms, p99_ms, max_ms, mean_ms (nearest-rank percentiles), and
// over_20ms (fraction of steps over the 50 Hz budget). With --benchmark_repetitions the
// aggregates (median, ...) are taken over the sequences.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <vector>

namespace nsim {

class StepTimes {
 public:
  explicit StepTimes(size_t expected) { ms_.reserve(expected); }

  /// Runs f() and records its wall time; returns f's result.
  template <class F>
  auto Time(F&& f) {
    const auto start = std::chrono::steady_clock::now();
    auto result = f();
    ms_.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    return result;
  }
  /// Time of the last recorded step (ms).
  double last() const { return ms_.back(); }
  /// Nearest-rank percentile of the recorded times (ms), 0 when none.
  double Percentile(double q) const { return Percentile(ms_, q); }

  /// Nearest-rank percentile (q in [0, 1]) of `values` (ms).
  static double Percentile(std::vector<double> values, double q) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const size_t rank = static_cast<size_t>(std::ceil(q * static_cast<double>(values.size())));
    return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
  }

  void Report(benchmark::State& state) const {
    if (ms_.empty()) return;
    state.counters["p50_ms"] = Percentile(ms_, 0.50);
    state.counters["p90_ms"] = Percentile(ms_, 0.90);
    state.counters["p99_ms"] = Percentile(ms_, 0.99);
    state.counters["max_ms"] = *std::max_element(ms_.begin(), ms_.end());
    state.counters["mean_ms"] = std::accumulate(ms_.begin(), ms_.end(), 0.0) / ms_.size();
    state.counters["over_20ms"] =
        static_cast<double>(std::count_if(ms_.begin(), ms_.end(), [](double t) { return t > 20.0; })) /
        ms_.size();
    state.counters["steps"] = static_cast<double>(ms_.size());
  }

 private:
  std::vector<double> ms_;
};

}  // namespace nsim
