#include "common/scene/physics_watchdog.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {

void WatchdogConfig::Validate() const {
  if (!(max_displacement > 0) || !std::isfinite(max_displacement))
    throw InputError(Str("watchdog.max_displacement must be > 0 (m), got ", max_displacement));
  if (!(max_kinetic_energy > 0) || !std::isfinite(max_kinetic_energy))
    throw InputError(Str("watchdog.max_kinetic_energy must be > 0 (J), got ", max_kinetic_energy));
  if (inversion_check_every < 0)
    throw InputError(
        Str("watchdog.inversion_check_every must be >= 0 (steps), got ", inversion_check_every));
  // a patient's liver is 0.3 m across: a bound of a metre checks nothing
  CheckAtMost(max_displacement, 1.0, "watchdog.max_displacement", "m");
  CheckAtMost(max_kinetic_energy, 1e6, "watchdog.max_kinetic_energy", "J");
  CheckAtMost(inversion_check_every, 1000000, "watchdog.inversion_check_every", "steps");
}

PhysicsWatchdog::PhysicsWatchdog(const WatchdogConfig& config, const Eigen::Vector3d& rest_target,
                                 const std::vector<Eigen::Vector3d>& rest_markers)
    : config_(config), rest_target_(rest_target), rest_markers_(rest_markers) {
  config_.Validate();
}

std::string PhysicsWatchdog::Check(const WatchdogInput& in) const {
  if (!in.target->allFinite()) return "the target position is not finite";
  if (!in.tip->allFinite()) return "the needle tip position is not finite";
  for (size_t i = 0; i < in.markers->size(); ++i)
    if (!(*in.markers)[i].allFinite()) return Str("marker ", i, " is not finite");
  if (!config_.enabled) return "";

  const double limit = config_.max_displacement;
  if (const double d = (*in.target - rest_target_).norm(); d > limit)
    return Str("the target moved ", 1e3 * d, " mm from its rest position (watchdog.max_displacement ",
               1e3 * limit, " mm)");
  for (size_t i = 0; i < in.markers->size() && i < rest_markers_.size(); ++i)
    if (const double d = ((*in.markers)[i] - rest_markers_[i]).norm(); d > limit)
      return Str("marker ", i, " moved ", 1e3 * d,
                 " mm from its rest position (watchdog.max_displacement ", 1e3 * limit, " mm)");

  const auto body = [&](const char* name, const FemModel* model,
                        const FemState* state) -> std::string {
    if (model == nullptr || state == nullptr) return "";
    const double energy = CalcKineticEnergy(*model, *state);
    if (!(energy <= config_.max_kinetic_energy))
      return Str("the ", name, "'s kinetic energy is ", energy,
                 " J (watchdog.max_kinetic_energy ", config_.max_kinetic_energy, " J)");
    const int every = config_.inversion_check_every;
    if (every > 0 && in.step % every == 0)
      if (const int inverted = CountInvertedTets(*model, *state); inverted > 0)
        return Str(inverted, " ", name, " element", inverted == 1 ? " is" : "s are",
                   " inverted (det F <= 0)");
    return "";
  };
  if (std::string why = body("liver", in.liver, in.liver_state); !why.empty()) return why;
  return body("skin", in.skin, in.skin_state);
}

}  // namespace nsim
