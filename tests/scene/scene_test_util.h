#pragma once
// Shared by the scene tests: the default scenario with the coarse 700-node liver (fast).

#include <string>

#include "common/mesh/gmsh_reader.h"
#include "direct_sim/scenario_loader.h"

namespace nsim::testing {

inline std::string SourcePath(const std::string& relative) {
  return std::string(NSIM_SOURCE_DIR) + "/" + relative;
}

/// configs/scenarios/liver_breathing.yaml with configs/meshes/liver_700.msh.
inline DirectScenario LoadCoarseScenario() {
  DirectScenario s = LoadDirectScenario(SourcePath("configs/scenarios/liver_breathing.yaml"));
  s.liver_mesh = ReadGmshMesh(SourcePath("configs/meshes/liver_700.msh"));
  return s;
}

}  // namespace nsim::testing
