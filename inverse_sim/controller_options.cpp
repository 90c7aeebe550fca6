#include "inverse_sim/controller_options.h"

#include "common/core/error.h"
#include "common/core/yaml_reader.h"

namespace nsim {

void AddControllerOptions(CommandLine& cli) {
  cli.Choice("prediction", "on|off", "register to predicted markers (default: the scenario's)",
             {"on", "off"})
      .Choice("dof", "cartesian6|joint7", "Jacobian DoF (default: the scenario's)",
              {"cartesian6", "joint7"})
      .Option("young-modulus-factor", "X", "factor on the controller model's Young's modulus")
      .Option("localization-delay", "S",
              "added to the predicted loop period to form the horizon (s), overrides "
              "prediction.localization_delay");
}

void ApplyControllerOptions(const CommandLine& cli, InverseScenario* s) {
  if (cli.Has("prediction")) s->loop.prediction_enabled = cli.GetString("prediction") == "on";
  if (cli.Has("dof")) s->loop.control.dof = ParseSteeringDof(cli.GetString("dof"), "--dof");
  if (cli.Has("young-modulus-factor")) {
    s->loop.model.young_modulus_factor = cli.GetDouble("young-modulus-factor");
    ValidateAs([&] { s->loop.model.Validate(); }, "--young-modulus-factor", "inverse.", "");
  }
  if (cli.Has("localization-delay")) {
    s->loop.horizon.localization_delay = cli.GetDouble("localization-delay");
    ValidateAs([&] { s->loop.horizon.Validate(); }, "--localization-delay", "horizon.", "");
    ResolveSearchLead(s);
    ValidateAs([&] { s->loop.prediction.Validate(); }, "--localization-delay", "prediction.", "");
  }
}

}  // namespace nsim
