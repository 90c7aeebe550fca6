#include "common/markers/tracker_noise.h"

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

std::mt19937_64 SeededEngine(uint64_t seed) {
  std::seed_seq seq{seed, uint64_t{0x747261636b6572}};  // "tracker"
  return std::mt19937_64(seq);
}

}  // namespace

void TrackerNoiseConfig::Validate() const {
  if (!(std::isfinite(marker_std) && marker_std >= 0.0 && marker_std <= 0.01))
    throw InputError(Str("tracker.marker_noise must be a standard deviation in [0, 0.01] m, got ",
                         marker_std));
}

TrackerNoise::TrackerNoise(const TrackerNoiseConfig& config)
    : config_(config), rng_(SeededEngine(config.random_seed)) {
  config_.Validate();
}

void TrackerNoise::Apply(std::vector<Eigen::Vector3d>* markers) {
  if (config_.marker_std == 0.0) return;
  for (Eigen::Vector3d& p : *markers) {
    for (int c = 0; c < 3; ++c) p[c] += config_.marker_std * normal_(rng_);
  }
}

}  // namespace nsim
