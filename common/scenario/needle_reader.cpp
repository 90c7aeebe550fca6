#include "common/scenario/needle_reader.h"

#include "common/core/error.h"

namespace nsim {

void ReadBevel(const YamlReader& node, BevelConfig* b) {
  node.CheckKeys(
      {"enabled", "diameter", "bevel_angle", "beta_over_alpha", "tissue_stiffness", "mode"});
  node.Read("enabled", &b->enabled);
  node.Read("diameter", &b->diameter);
  node.Read("bevel_angle", &b->bevel_angle);
  node.Read("beta_over_alpha", &b->beta_over_alpha);
  node.Read("tissue_stiffness", &b->tissue_stiffness);
  const int mode = node.ReadChoice("mode", {"torque", "force"});
  if (mode >= 0) b->mode = mode == 0 ? BevelLoadMode::kTorque : BevelLoadMode::kForce;
}

const std::vector<std::string>& NeedleMaterialKeys() {
  static const std::vector<std::string> keys = {"young_modulus",      "poisson_ratio",
                                                "density",            "elements",
                                                "rayleigh_mass",      "rayleigh_stiffness"};
  return keys;
}

void ReadNeedleMaterial(const YamlReader& node, NeedleConfig* g, BeamNeedleConfig* beam) {
  node.Read("young_modulus", &g->young_modulus);
  node.Read("poisson_ratio", &g->poisson_ratio);
  node.Read("density", &g->density);
  // checked here: the beam's own check names its field (num_elements), not this key
  if (node.Read("elements", &beam->num_elements) && beam->num_elements < 1)
    throw InputError(Str(node.Where("elements"), " must be >= 1, got ", beam->num_elements));
  node.Read("rayleigh_mass", &beam->rayleigh_mass);
  node.Read("rayleigh_stiffness", &beam->rayleigh_stiffness);
}

const std::vector<std::string>& TissueCouplingKeys() {
  static const std::vector<std::string> keys = {
      "puncture_force", "friction_coefficient", "friction_force_per_length",
      "point_spacing",  "tip_constraint",       "tip_hold",
      "seed_distance",  "contact_margin",       "lateral_compliance",
      "tip_compliance"};
  return keys;
}

void ReadTissueCoupling(const YamlReader& node, TissueCouplingConfig* t) {
  node.Read("puncture_force", &t->puncture_force);
  node.Read("friction_coefficient", &t->friction_coefficient);
  node.Read("friction_force_per_length", &t->friction_force_per_length);
  node.Read("point_spacing", &t->point_spacing);
  node.Read("tip_constraint", &t->tip_constraint);
  const int tip_hold = node.ReadChoice("tip_hold", TipHoldNames());
  if (tip_hold >= 0) t->tip_hold = static_cast<TipHold>(tip_hold);
  const int measure = node.ReadChoice("seed_distance", SeedDistanceNames());
  if (measure >= 0) t->seed_distance = static_cast<SeedDistance>(measure);
  node.Read("contact_margin", &t->contact_margin);
  node.Read("lateral_compliance", &t->lateral_compliance);
  node.Read("tip_compliance", &t->tip_compliance);
}

}  // namespace nsim
