#pragma once
// Loads the inverse side of a scenario file: the `shared:` section (markers at rest, entry,
// target, needle geometry, approach, robot base: written once for both processes), the
// `inverse:` (the liver model), `controller:` (path, Jacobian, law) and `prediction:` (marker
// prediction, horizon) sections, and the shared `dds:` (domain, partition) and `run.mode`
// (lockstep: answer every frame in order). The direct sections are not loaded; that both
// processes run the same shared part is checked at the start handshake (SimStatus
// scenario_hash). Only this loader knows YAML; the libraries get the config structs.

#include <string>

#include "common/prediction/horizon_estimator.h"
#include "common/prediction/marker_predictor.h"
#include "common/scenario/shared_scenario.h"
#include "common/steering/controller_loop.h"
#include "common/steering/steering_config.h"

namespace nsim {

/// Everything inverse_sim run needs from the scenario.
struct InverseScenario {
  std::string source;      ///< the file it came from
  SharedScenario shared;   ///< the `shared:` section, applied to the configs below
  uint64_t scenario_hash = 0;  ///< ScenarioHash(shared), checked at the start handshake
  std::string mesh_path;   ///< inverse liver mesh (.msh), resolved relative to the scenario file
  /// the controller loop: the `inverse:` (model), `controller:` (path, law) and `prediction:`
  /// (prediction, horizon) sections
  ControllerLoopConfig loop;
  /// run.mode of the direct side (read from the same file): in lockstep inverse_sim answers
  /// every frame in order, so a run does not depend on timing.
  bool lockstep = false;
  int dds_domain = 0;                ///< dds.domain (default 0)
  std::string dds_partition = "nsim";  ///< dds.partition (default nsim)

  /// The controller loop's config for this run: in lockstep the model's refresh worker stays in
  /// the normal class (FemConfig::idle_refresh_worker), also with when_ready adoptions: the
  /// frames wait for the controller, and a busy machine starves the idle class. (Scheduled
  /// adoptions, the default, keep it there in any mode: FemConfig::RefreshWorkerIdle.)
  /// Otherwise `loop` as read.
  ControllerLoopConfig LoopConfig() const {
    ControllerLoopConfig config = loop;
    if (lockstep) config.model.liver.idle_refresh_worker = false;
    return config;
  }
};

/// Reads and validates the three sections. InputError "<file>: <key>: ..." on a missing or
/// malformed key, an unknown key, or an invalid value.
InverseScenario LoadInverseScenario(const std::string& path);

/// With loop.search_lead_auto: prediction.search_lead = max(1, round((localization_delay
/// + time_step) / time_step)), the horizon in frames; otherwise unchanged. Call after any
/// override of horizon.localization_delay.
void ResolveSearchLead(InverseScenario* scenario);

}  // namespace nsim
