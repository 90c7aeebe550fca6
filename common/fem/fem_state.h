#pragma once
// The mutable state of one FEM body (MuJoCo mjData / Drake FemState style). Everything is
// preallocated by the constructor; a copy is a handful of O(#nodes + #tets) buffers (about
// 1.2 MB for the 2660-node liver), so perturbations can be evaluated on copies without side
// effects on the original.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "common/fem/fem_model.h"

namespace nsim {

struct FemState {
  /// State at rest: x = rest positions, v = 0, identity rotations, prescribed positions at rest.
  explicit FemState(const FemModel& model);

  double time = 0.0;          ///< simulation time t (s)
  Eigen::Matrix3Xd x;         ///< node positions (m), 3 x #nodes, world frame
  Eigen::Matrix3Xd v;         ///< node velocities (m/s), 3 x #nodes
  /// User nodal forces (N), 3 x #nodes (e.g. needle forces), held constant over the next step.
  /// Forces on Dirichlet nodes go to the support (they appear in reaction_forces).
  Eigen::Matrix3Xd external_forces;
  /// Positions (m) the prescribed nodes must reach at the end of the next step (time + h),
  /// 3 x #prescribed in FemModel::get_prescribed_nodes() order. Set before each step.
  Eigen::Matrix3Xd prescribed_positions;

  /// Element rotations R_e of the last assembled step (polar rotation of F at that step's x).
  std::vector<Eigen::Matrix3d> rotations;
  /// Free-motion velocity change dv_free (m/s), 3 x #nodes, written by FemSolver::BeginStep;
  /// Dirichlet columns hold their prescribed dv.
  Eigen::Matrix3Xd dv_free;
  /// The free motion's end velocity v + dv_free of the last step (m/s), 3 x #nodes (zero at
  /// rest), and its changes from step to step, newest first (the last three; zero at rest).
  /// The next step's PCG warm start predicts the free end velocity from them, by the
  /// polynomial of order warm_start_order (1 constant, 2 line, 3 parabola: the one that
  /// predicted the last change best; common/fem/warm_start.h), and starts from that minus the
  /// step's v, which includes the constraints' correction of the step before.
  Eigen::Matrix3Xd free_velocity;
  std::array<Eigen::Matrix3Xd, 3> free_velocity_changes;
  int warm_start_order = 1;
  /// Free-motion positions x + h (v + dv_free) (m), 3 x #nodes, written by BeginStep.
  Eigen::Matrix3Xd x_free;
  /// Reaction forces the supports exert on the Dirichlet nodes during the last committed step
  /// (N), 3 x #Dirichlet in FemModel::get_dirichlet_nodes() order (fixed, then prescribed).
  Eigen::Matrix3Xd reaction_forces;

  /// Number of nodes the state was made for.
  int num_nodes() const { return static_cast<int>(x.cols()); }
};

/// Kinetic energy 0.5 sum_i m_i |v_i|^2 (J) with the lumped mass.
double CalcKineticEnergy(const FemModel& model, const FemState& state);

/// Co-rotated elastic strain energy (J) at state.x: sum_e V_e (mu eps:eps + lambda/2 tr(eps)^2),
/// eps = R_e^T F_e - I with R_e the polar rotation recomputed from state.x (not state.rotations).
double CalcElasticEnergy(const FemModel& model, const FemState& state);

/// Gravitational potential energy -sum_i m_i g . x_i (J), zero at the world origin.
double CalcGravitationalEnergy(const FemModel& model, const FemState& state);

/// Number of elements whose deformation gradient at state.x has det F <= 0 (inverted or
/// flattened: no physical state of the continuum has one).
int CountInvertedTets(const FemModel& model, const FemState& state);

/// Elastic forces (N), 3 x #nodes, at state.x with fresh polar rotations (zero for rigid motions).
Eigen::Matrix3Xd CalcElasticForces(const FemModel& model, const FemState& state);

}  // namespace nsim
