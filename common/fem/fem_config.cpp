#include "common/fem/fem_config.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {

FemLinearSolver ParseFemLinearSolver(const std::string& text, const std::string& key) {
  if (text == "direct") return FemLinearSolver::kDirect;
  if (text == "pcg_cached_factor") return FemLinearSolver::kPcgCachedFactor;
  throw InputError(Str(key, " must be \"direct\" or \"pcg_cached_factor\", got \"", text, "\""));
}

void FemConfig::Validate() const {
  // NaN-safe: every comparison is written so that NaN fails it
  if (!(young_modulus > 0.0 && std::isfinite(young_modulus)))
    throw InputError(Str("fem.young_modulus must be > 0 (Pa), got ", young_modulus));
  if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    throw InputError(Str("fem.poisson_ratio must be in (-1, 0.5), got ", poisson_ratio));
  if (!(density > 0.0 && std::isfinite(density)))
    throw InputError(Str("fem.density must be > 0 (kg/m^3), got ", density));
  if (!(rayleigh_mass >= 0.0 && std::isfinite(rayleigh_mass)))
    throw InputError(Str("fem.rayleigh_mass must be >= 0 (1/s), got ", rayleigh_mass));
  if (!(rayleigh_stiffness >= 0.0 && std::isfinite(rayleigh_stiffness)))
    throw InputError(Str("fem.rayleigh_stiffness must be >= 0 (s), got ", rayleigh_stiffness));
  if (!(time_step > 0.0 && std::isfinite(time_step)))
    throw InputError(Str("fem.time_step must be > 0 (s), got ", time_step));
  if (!gravity.allFinite())
    throw InputError(Str("fem.gravity must be finite (m/s^2), got ", gravity.transpose()));
  if (!(cg_relative_tolerance > 0.0 && cg_relative_tolerance < 1.0))
    throw InputError(Str("fem.cg_relative_tolerance must be in (0, 1), got ", cg_relative_tolerance));
  if (!(cg_max_iterations >= 1))
    throw InputError(Str("fem.cg_max_iterations must be >= 1, got ", cg_max_iterations));
  // a preconditioned CG that needs more than 1e5 iterations has failed anyway
  CheckAtMost(cg_max_iterations, 1e5, "fem.cg_max_iterations", "");
  if (!(refactor_iteration_threshold >= 1))
    throw InputError(
        Str("fem.refactor_iteration_threshold must be >= 1, got ", refactor_iteration_threshold));
  if (!(refactor_adopt_delay >= 1))
    throw InputError(Str("fem.refactor_adopt_delay must be >= 1 (steps), got ", refactor_adopt_delay));
  if (!(refactor_slice >= 0.0 && refactor_slice <= 1.0))
    throw InputError(Str("fem.refactor_slice must be in [0, 1] (s), got ", refactor_slice));
  if (!(refactor_hold_steps >= 0))
    throw InputError(Str("fem.refactor_hold_steps must be >= 0 (steps), got ", refactor_hold_steps));
  CheckAtMost(refactor_hold_steps, 1e6, "fem.refactor_hold_steps", "steps");
  if (!(element_threads >= 1 && element_threads <= 8))
    throw InputError(Str("fem.element_threads must be in [1, 8], got ", element_threads));
}

LameParameters CalcLameParameters(double young_modulus, double poisson_ratio) {
  LameParameters lame;
  lame.lambda =
      young_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
  lame.mu = young_modulus / (2.0 * (1.0 + poisson_ratio));
  return lame;
}

}  // namespace nsim
