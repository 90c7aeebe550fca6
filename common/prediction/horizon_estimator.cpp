#include "common/prediction/horizon_estimator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/prediction/polynomial_filter.h"

namespace nsim {

void HorizonConfig::Validate() const {
  if (window < 2) throw InputError(Str("horizon.window must be >= 2, got ", window));
  if (optimize_window && window_max < 4)
    throw InputError(
        Str("horizon.window_max must be >= 4 to search [2, window_max - 1], got ", window_max));
  const int needed = std::max(window, optimize_window ? window_max + 2 : 0);
  if (history < needed)
    throw InputError(Str("horizon.history must be >= ", needed,
                         " (window, or window_max + 2 when optimizing), got ", history));
  if (search_interval < 0)
    throw InputError(Str("horizon.search_interval must be >= 0, got ", search_interval));
  if (!(localization_delay >= 0) || !std::isfinite(localization_delay))
    throw InputError(Str("horizon.localization_delay must be >= 0 (s), got ", localization_delay));
  // a tracker's delay is ms..100 ms; 10 s is more than two breathing cycles: no prediction
  CheckAtMost(localization_delay, 10.0, "horizon.localization_delay", "s");
  // the history is allocated at its size: 1e5 samples is over half an hour at 50 Hz
  CheckAtMost(window, 100000, "horizon.window", "samples");
  CheckAtMost(window_max, 100000, "horizon.window_max", "samples");
  CheckAtMost(history, 1000000, "horizon.history", "samples");
}

HorizonEstimator::HorizonEstimator(const HorizonConfig& config) : config_(config) {
  config_.Validate();
  ring_.assign(config_.history, 0.0);
  times_.assign(config_.history, 0.0);
  index_.resize(config_.history);
  for (int i = 0; i < config_.history; ++i) index_[i] = i;
  window_ = config_.window;
}

void HorizonEstimator::AddLoopTime(double t) {
  if (!std::isfinite(t)) throw InputError(Str("loop time must be finite, got ", t));
  if (size_ > 0) {
    const double last = ring_[(head_ + config_.history - 1) % config_.history];
    if (!(t > last))
      throw InputError(Str("loop time must increase: got ", t, " s after ", last, " s"));
  }
  ring_[head_] = t;
  head_ = (head_ + 1) % config_.history;
  if (size_ < config_.history) ++size_;
  if (!config_.optimize_window || size_ < config_.history) return;
  if (searched_ && !(config_.search_interval > 0 && ++since_search_ >= config_.search_interval))
    return;
  // Algorithm 1 on the timestamps: one-step cost of the order-1 filter, WF in [2, WL - 1]
  CopyChronological(size_);
  window_ = SearchWindow(index_.data(), times_.data(), size_, 1, 2, config_.window_max - 1, 1).x;
  searched_ = true;
  since_search_ = 0;
}

void HorizonEstimator::CopyChronological(int count) {
  for (int i = 0; i < count; ++i)
    times_[i] = ring_[(head_ - count + i + 2 * config_.history) % config_.history];
}

double HorizonEstimator::PredictNextLoopTime() {
  if (size_ == 0) return std::numeric_limits<double>::quiet_NaN();
  if (size_ == 1) return ring_[(head_ + config_.history - 1) % config_.history];
  const int n = std::min(size_, window_);
  CopyChronological(n);
  // eq. 4.8-4.9: regress t on the index 0 .. n-1, evaluate at index n
  return ExtrapolatePolynomial(index_.data(), times_.data(), n, 1, n);
}

double HorizonEstimator::CalcHorizon(double t_sample) {
  const double next = PredictNextLoopTime();
  if (!std::isfinite(next)) return config_.localization_delay;
  return std::max(0.0, next - t_sample + config_.localization_delay);
}

}  // namespace nsim
