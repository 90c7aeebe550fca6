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

}  // namespace nsim
