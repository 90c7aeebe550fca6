#pragma once
// Loads the inverse side of a scenario file: the `inverse:` (the liver model), `controller:`
// (path, Jacobian, law) and `prediction:` (marker prediction, horizon) sections. The rest of
// the file belongs to the direct side and is not read here. Only this loader knows YAML; the
// libraries get the config structs.

#include <string>

#include "common/prediction/horizon_estimator.h"
#include "common/prediction/marker_predictor.h"
#include "common/steering/steering_config.h"

namespace nsim {

/// Everything inverse_sim run needs from the scenario.
struct InverseScenario {
  std::string source;      ///< the file it came from
  std::string mesh_path;   ///< inverse liver mesh (.msh), resolved relative to the scenario file
  InverseModelConfig model;
  SteeringPathConfig path;
  SteeringControlConfig control;
  bool prediction_enabled = true;  ///< register to predicted markers (thesis fig. 4.4)
  PredictionConfig prediction;
  HorizonConfig horizon;
};

/// Reads and validates the three sections. InputError "<file>: <key>: ..." on a missing or
/// malformed key, an unknown key, or an invalid value.
InverseScenario LoadInverseScenario(const std::string& path);

}  // namespace nsim
