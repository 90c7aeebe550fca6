#pragma once
// The material, damping and solver keys of an FEM body in a scenario file (patient.liver,
// patient.skin, inverse.liver): one reader for both processes' loaders.

#include <string>
#include <vector>

#include "common/core/yaml_reader.h"
#include "common/fem/fem_config.h"

namespace nsim {

/// The keys ReadFemConfig reads: young_modulus, poisson_ratio, density, rayleigh_mass,
/// rayleigh_stiffness, linear_solver (direct | pcg_cached_factor), cg_relative_tolerance,
/// cg_max_iterations, refactor_iteration_threshold, background_refactor,
/// refactor_adopt_delay, refactor_adoption (scheduled | when_ready), refactor_slice (s),
/// refactor_hold_steps,
/// element_threads,
/// preconditioner_precision (single | double). The
/// caller checks them with its own keys (CheckKeys), since a section holds more (mesh, pose).
const std::vector<std::string>& FemConfigKeys();

/// Reads the keys present at `node` into `fem`, leaving the others as they are; InputError
/// naming the key for a value of the wrong type or an unknown choice. The values' ranges are
/// checked by FemConfig::Validate.
void ReadFemConfig(const YamlReader& node, FemConfig* fem);

}  // namespace nsim
