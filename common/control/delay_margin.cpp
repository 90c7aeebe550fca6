#include "common/control/delay_margin.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace nsim {

double CalcDelayedIntegratorGainLimit(int d) {
  if (d < 0) throw std::invalid_argument("CalcDelayedIntegratorGainLimit: the delay must be >= 0");
  // on the unit circle z = e^(i w): |z - 1| = g at the crossing, with the phase condition
  // (d + 1/2) w = pi / 2, so g = 2 sin(w / 2) = 2 sin(pi / (2 (2 d + 1)))
  return 2.0 * std::sin(M_PI / (2.0 * (2.0 * d + 1.0)));
}

double LimitGainForDelay(double gain, int d, double margin) {
  if (!(margin >= 1.0)) throw std::invalid_argument("LimitGainForDelay: the margin must be >= 1");
  return std::min(gain, CalcDelayedIntegratorGainLimit(d) / margin);
}

}  // namespace nsim
