#pragma once
// The static-liver test scene shared by the steering tests and the benchmark: a committed liver
// mesh held by five registered markers at rest, a straight insertion along -y (anterior to
// posterior) into the right lobe, the target 8 cm below the entry.

#include <string>

#include "common/mesh/gmsh_reader.h"
#include "common/steering/steering_config.h"

namespace nsim {
namespace steering_test {

inline TetMesh LoadLiver(const std::string& name) {
  return ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/" + name + ".msh");
}

inline InverseModelConfig MakeModelConfig(double young_modulus_factor = 1.0) {
  InverseModelConfig c;
  c.liver.linear_solver = FemLinearSolver::kDirect;
  c.young_modulus_factor = young_modulus_factor;
  c.markers_W = {{0.0, 0.0, 0.03},   {0.07, 0.0, -0.03}, {0.035, 0.02, 0.05},
                 {0.035, -0.03, -0.05}, {0.06, 0.03, 0.0}};
  return c;
}

inline SteeringPathConfig MakePathConfig() {
  SteeringPathConfig p;
  p.entry_W = {0.035, 0.054, 0.0};
  p.target_W = {0.035, -0.026, 0.0};  // 8 cm deep
  p.approach_distance = 0.01;
  p.spacing = 0.01;
  return p;
}

}  // namespace steering_test
}  // namespace nsim
