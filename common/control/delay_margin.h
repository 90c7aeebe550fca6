#pragma once
// The gain limit of a control loop that acts on a measurement d steps old without compensating
// the commands in flight: eps(k+1) = eps(k) - g eps(k - d), characteristic polynomial
// z^(d+1) - z^d + g. Its roots leave the unit circle at g = 2 sin(pi / (2 (2 d + 1))) (1 at
// d = 1, 0.445 at 3, 0.285 at 5, 0.149 at 10); the controller gives the objectives whose
// in-flight compensation it cannot trust (the liver's load, README "The liver's load") at most
// that limit over a gain margin.

namespace nsim {

/// The largest stable gain of the delayed integrator above for d >= 0 steps of delay (2 at
/// d = 0). Throws std::invalid_argument for d < 0.
double CalcDelayedIntegratorGainLimit(int d);

/// min(gain, CalcDelayedIntegratorGainLimit(d) / margin); margin >= 1.
double LimitGainForDelay(double gain, int d, double margin);

}  // namespace nsim
