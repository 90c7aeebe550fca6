#include "common/prediction/exhale_gate.h"

#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

void ExhaleGateConfig::Validate() const {
  if (capacity < 3) throw InputError(Str("exhale gate: capacity must be >= 3 frames, got ", capacity));
  if (!(band > 0.0 && band < 0.5))
    throw InputError(Str("exhale gate: band must be in (0, 0.5), got ", band));
  if (!(min_range >= 0.0) || !std::isfinite(min_range))
    throw InputError(Str("exhale gate: min_range must be >= 0 (m), got ", min_range));
}

ExhaleGate::ExhaleGate(const ExhaleGateConfig& config)
    : config_((config.Validate(), config)), buffer_(config.capacity) {
  scratch_.reserve(config.capacity);
}

bool ExhaleGate::Add(double t, const Eigen::Vector3d& centroid) {
  buffer_.Push(t, centroid);
  if (!buffer_.full()) return false;
  buffer_.CalcPrincipalAxes(&axes_);
  const int n = buffer_.size();
  scratch_.resize(n);
  for (int i = 0; i < n; ++i) scratch_[i] = axes_.Project(buffer_.position(i));
  const double now = scratch_[n - 1], before = scratch_[n - 2];
  const auto [lo, hi] = std::minmax_element(scratch_.begin(), scratch_.end());
  const double low = *lo, high = *hi;
  range_ = high - low;
  if (range_ < config_.min_range) return true;
  std::nth_element(scratch_.begin(), scratch_.begin() + n / 2, scratch_.end());
  const double median = scratch_[n / 2];
  // the rest (exhale) is the extreme the median is nearer to; the band is measured from it
  const bool rest_high = high - median < median - low;
  const double edge = rest_high ? high - config_.band * range_ : low + config_.band * range_;
  auto inside = [&](double s) { return rest_high ? s >= edge : s <= edge; };
  return inside(now) && !inside(before);
}

}  // namespace nsim
