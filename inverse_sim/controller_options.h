#pragma once
// The command-line options that tune the controller, shared by `inverse_sim run` and the
// in-process closed loop (`direct_sim run --in-process`): one declaration, one meaning.

#include "common/core/cli.h"
#include "inverse_sim/scenario_loader.h"

namespace nsim {

/// Adds --prediction, --dof, --young-modulus-factor and --localization-delay.
void AddControllerOptions(CommandLine& cli);

/// Applies the options given on the command line to `scenario` (InputError naming the option
/// for a bad value).
void ApplyControllerOptions(const CommandLine& cli, InverseScenario* scenario);

}  // namespace nsim
