#pragma once
// Needle sections of a scenario file, read by both processes' loaders: the bevel tip
// (needle.bevel of the patient, inverse.bevel of the controller's model) and the needle's
// material and beam discretization (needle.* of the patient, inverse.needle of the model), and
// the needle-tissue coupling (needle.<tissue> of the patient, inverse.* of the model's liver).
// The readers check the keys; the values are validated by the config structs' Validate().

#include "common/core/yaml_reader.h"
#include "common/needle/beam_needle.h"
#include "common/needle/bevel_tip.h"
#include "common/needle/needle_tissue.h"
#include "common/needle/rigid_needle.h"

namespace nsim {

/// {enabled, diameter, bevel_angle, beta_over_alpha, tissue_stiffness, mode: torque | force}
/// into `bevel` (absent keys keep their values); InputError naming the key on an unknown key or
/// a bad value.
void ReadBevel(const YamlReader& node, BevelConfig* bevel);

/// The keys of ReadNeedleMaterial.
const std::vector<std::string>& NeedleMaterialKeys();

/// young_modulus, poisson_ratio, density into `needle`; elements, rayleigh_mass,
/// rayleigh_stiffness into `beam` (absent keys keep their values). Does not check for unknown
/// keys (the caller's section has its own, see NeedleMaterialKeys).
void ReadNeedleMaterial(const YamlReader& node, NeedleConfig* needle, BeamNeedleConfig* beam);

/// The keys of ReadTissueCoupling.
const std::vector<std::string>& TissueCouplingKeys();

/// puncture_force, friction_coefficient, friction_force_per_length, point_spacing,
/// tip_constraint, tip_hold, seed_distance, contact_margin, lateral_compliance, tip_compliance
/// into `coupling` (absent keys keep their values). Does not check for unknown keys (the
/// caller's section may have its own, see TissueCouplingKeys).
void ReadTissueCoupling(const YamlReader& node, TissueCouplingConfig* coupling);

}  // namespace nsim
