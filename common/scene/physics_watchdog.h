#pragma once
// The physics watchdog of the patient loop (issue #15 "a run whose state leaves plausible
// bounds stops"): after every step it checks that the state is one a patient could be in. A
// state that is not (a non-finite value, the target or a marker far from where it rests, an
// exploding kinetic energy, an inverted element) ends the run as a runtime failure with the
// reason, never as a completed run whose numbers would be garbage.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/fem/fem_model.h"
#include "common/fem/fem_state.h"

namespace nsim {

/// The plausible bounds. The defaults leave a wide margin over the thesis's scene (breathing
/// moves the liver about 12 mm, its kinetic energy stays below 1e-3 J).
struct WatchdogConfig {
  bool enabled = true;
  /// The target and every marker stay within this distance of their rest positions (m).
  double max_displacement = 0.1;
  /// The kinetic energy of the liver and of the skin, each, stays below this (J).
  double max_kinetic_energy = 10.0;
  /// No liver or skin element may be inverted (det F <= 0); checked every this many steps
  /// (0: never). One check costs about one element loop without the polar decomposition.
  int inversion_check_every = 1;

  /// Throws InputError "watchdog.<key> ..." for a value out of range.
  void Validate() const;
};

/// What the watchdog looks at after a step (positions in m).
struct WatchdogInput {
  int64_t step = 0;
  const Eigen::Vector3d* target = nullptr;
  const std::vector<Eigen::Vector3d>* markers = nullptr;
  const Eigen::Vector3d* tip = nullptr;
  const FemModel* liver = nullptr;
  const FemState* liver_state = nullptr;
  const FemModel* skin = nullptr;  ///< null without a skin
  const FemState* skin_state = nullptr;
};

class PhysicsWatchdog {
 public:
  /// `rest_target` and `rest_markers`: where the target and the markers rest (m).
  PhysicsWatchdog(const WatchdogConfig& config, const Eigen::Vector3d& rest_target,
                  const std::vector<Eigen::Vector3d>& rest_markers);

  /// Checks one state: an empty string when it is plausible, else why not (the first bound it
  /// breaks, with the value and the limit's key). Non-finite values are always checked, even
  /// when the watchdog is disabled.
  std::string Check(const WatchdogInput& in) const;

  const WatchdogConfig& config() const { return config_; }

 private:
  WatchdogConfig config_;
  Eigen::Vector3d rest_target_;
  std::vector<Eigen::Vector3d> rest_markers_;
};

}  // namespace nsim
