#pragma once
// A soft block and a rigid needle above it, shared by the needle tests.

#include <Eigen/Geometry>
#include <memory>

#include "common/constraints/fem_body.h"
#include "common/fem/fem_solver.h"
#include "common/mesh/tet_mesh.h"
#include "common/needle/needle_insertion.h"

namespace nsim::testing {

/// A FEM block [origin, origin + size] with its bottom face (z = origin.z) fixed.
struct FemBlock {
  TetMesh mesh;
  std::unique_ptr<FemModel> model;
  std::unique_ptr<FemSolver> solver;
  std::unique_ptr<FemState> state;
  std::unique_ptr<FemConstraintBody> body;

  FemBlock(const Eigen::Vector3i& nodes, const Eigen::Vector3d& size, const Eigen::Vector3d& origin,
           double young_modulus = 5000.0) {
    mesh = MakeBoxTetMesh(nodes, size, origin);
    FemBoundary boundary;
    for (int i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.X(2, i) < origin.z() + 1e-9) boundary.fixed_nodes.push_back(i);
    FemConfig config;
    config.young_modulus = young_modulus;
    config.rayleigh_mass = 1.0;
    config.rayleigh_stiffness = 0.01;
    config.gravity.setZero();
    config.linear_solver = FemLinearSolver::kDirect;
    model = std::make_unique<FemModel>(mesh, config, boundary);
    solver = std::make_unique<FemSolver>(*model);
    state = std::make_unique<FemState>(*model);
    body = std::make_unique<FemConstraintBody>(*solver, *state);
  }
};

/// Flange pose pointing the flange z axis (the needle) along -Z_W, base at `base`.
inline Eigen::Isometry3d DownwardFlange(const Eigen::Vector3d& base) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  X.translation() = base;
  return X;
}

}  // namespace nsim::testing
