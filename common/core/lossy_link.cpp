#include "common/core/lossy_link.h"

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

std::mt19937_64 MakeGenerator(uint64_t seed, uint64_t stream) {
  std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                    static_cast<uint32_t>(stream), static_cast<uint32_t>(stream >> 32)};
  return std::mt19937_64(seq);
}

}  // namespace

LossyLink::LossyLink(double percent, uint64_t seed, uint64_t stream, const char* name)
    : probability_(percent / 100.0), rng_(MakeGenerator(seed, stream)) {
  CheckPercent(percent, name);
}

void LossyLink::CheckPercent(double percent, const char* name) {
  if (!(percent >= 0.0 && percent <= 100.0))
    throw InputError(Str(name, " must be in [0, 100] (percent), got ", percent));
}

bool LossyLink::Drop() {
  ++sent_;
  // a uniform double in [0, 1) from the top 53 bits: the same draws with any standard library
  // (std::bernoulli_distribution's algorithm is the library's own)
  const double u = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
  const bool lost = u < probability_;
  lost_ += lost ? 1 : 0;
  return lost;
}

}  // namespace nsim
