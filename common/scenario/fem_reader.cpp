#include "common/scenario/fem_reader.h"

namespace nsim {

const std::vector<std::string>& FemConfigKeys() {
  static const std::vector<std::string> keys = {
      "young_modulus",       "poisson_ratio",        "density",
      "rayleigh_mass",       "rayleigh_stiffness",   "linear_solver",
      "cg_relative_tolerance", "cg_max_iterations",  "refactor_iteration_threshold",
      "background_refactor", "refactor_adopt_delay", "element_threads",
      "preconditioner_precision", "refactor_adoption", "refactor_slice", "refactor_hold_steps"};
  return keys;
}

void ReadFemConfig(const YamlReader& node, FemConfig* fem) {
  node.Read("young_modulus", &fem->young_modulus);
  node.Read("poisson_ratio", &fem->poisson_ratio);
  node.Read("density", &fem->density);
  node.Read("rayleigh_mass", &fem->rayleigh_mass);
  node.Read("rayleigh_stiffness", &fem->rayleigh_stiffness);
  if (std::string solver; node.Read("linear_solver", &solver))
    fem->linear_solver = ParseFemLinearSolver(solver, node.Where("linear_solver"));
  node.Read("cg_relative_tolerance", &fem->cg_relative_tolerance);
  node.Read("cg_max_iterations", &fem->cg_max_iterations);
  node.Read("refactor_iteration_threshold", &fem->refactor_iteration_threshold);
  node.Read("background_refactor", &fem->background_refactor);
  node.Read("refactor_adopt_delay", &fem->refactor_adopt_delay);
  node.Read("element_threads", &fem->element_threads);
  node.Read("refactor_slice", &fem->refactor_slice);
  node.Read("refactor_hold_steps", &fem->refactor_hold_steps);
  const int adoption = node.ReadChoice("refactor_adoption", {"scheduled", "when_ready"});
  if (adoption >= 0)
    fem->refactor_adoption = adoption == 0 ? FactorAdoption::kScheduled : FactorAdoption::kWhenReady;
  const int precision = node.ReadChoice("preconditioner_precision", {"single", "double"});
  if (precision >= 0) fem->single_precision_preconditioner = precision == 0;
}

}  // namespace nsim
