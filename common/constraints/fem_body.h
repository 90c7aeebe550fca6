#pragma once
// Adapter between one FEM body (common/fem: FemSolver + FemState) and the constraint solver.
// Step protocol (free motion, then correction; thesis §3.1, Duriez 2009):
//
//   FemConstraintBody body(fem_solver, fem_state);
//   body.BeginStep();                 // free motion: state.x_free, state.dv_free
//   set.Clear(); set.AddBody(body); ...rows...;
//   constraint_solver.Solve(set);     // ApplyCompliance, then ApplyCorrection -> CommitStep
//   body.EndStep();                   // commits without correction if no solve did
//
// The compliance is C = h^2 A^-1 with the operator selected by FemInverse (see fem_solver.h):
// kReferenceFactor (default: the last factor's exact inverse, unwarped; constant between
// factorizations, so compliance_version() only changes when the factor does and the columns of
// persistent constraint points are reused across steps; moves rigid translations rigidly),
// kRestFactor (the rest system's exact inverse, A_0^-1: compliance_version() never changes, so
// cached columns survive every refresh of the solver's factor, including background ones; the
// patient liver's default), kCachedFactor (the factor warped by nodal rotations; changes every step) or kCurrentSystem
// (exact, but one PCG per column on the PCG path). The correction is applied with the same
// operator, so constraints are met by the corrected state in every mode.

#include <Eigen/Core>

#include "common/constraints/constraint_body.h"
#include "common/fem/fem_solver.h"
#include "common/fem/fem_state.h"

namespace nsim {

class FemConstraintBody : public ConstraintBody {
 public:
  /// solver and state (of solver's model) must outlive the adapter.
  FemConstraintBody(FemSolver& solver, FemState& state,
                    FemInverse compliance = FemInverse::kReferenceFactor);

  /// Free motion of the step (FemSolver::BeginStep); starts a new compliance version unless
  /// the operator is the rest factor or the unchanged reference factor.
  FemStepStats BeginStep();
  /// Ends the step without a correction unless ApplyCorrection already committed it.
  void EndStep();
  /// True between BeginStep and the commit of the step.
  bool in_step() const { return in_step_; }

  int num_nodes() const override { return state_.num_nodes(); }
  const Eigen::Matrix3Xd& start_positions() const override { return state_.x; }
  const Eigen::Matrix3Xd& free_positions() const override { return state_.x_free; }
  /// h^2 A^-1 forces; rows of Dirichlet nodes are zero. Valid between BeginStep and the commit;
  /// with kRestFactor at any time (A_0 does not change).
  void ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                       Eigen::MatrixXd& displacements) const override;
  std::uint64_t compliance_version() const override { return version_; }
  /// Commits the step with dv = dx / h (FemSolver::CommitStep). Once per step.
  void ApplyCorrection(const Eigen::Matrix3Xd& dx) override;

  FemState& state() { return state_; }
  const FemState& state() const { return state_; }
  FemSolver& solver() { return solver_; }

 private:
  FemSolver& solver_;
  FemState& state_;
  FemInverse which_;
  double h_;
  bool in_step_ = false;
  std::uint64_t version_ = 0;
  std::uint64_t factor_version_ = 0;  // solver factor version at the last BeginStep
  Eigen::VectorXd dv_;  // scratch: 3n velocity correction
};

}  // namespace nsim
