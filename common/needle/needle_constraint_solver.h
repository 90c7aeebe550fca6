#pragma once
// Constraint resolution for needle-tissue coupling with axial Coulomb friction whose normal
// force is the lateral constraint force (Duriez 2009; thesis §2.1.3, §3.1).
//
// The generic ConstraintSolver knows bilateral, unilateral and contact-friction laws; the
// needle's axial friction is different: the tissue point is held on the needle line by two
// bilateral lateral rows (any sign), and the axial row's force is bounded by
//     |lambda_axial| <= mu |(lambda_lat1, lambda_lat2)| + f_0,
// f_0 a constant stiction force (N). This solver builds W and delta with the generic assembler
// (same units, see constraint_body.h), then finds lambda by an active-set method on direct
// LDLT solves: every row is either free (bilateral, active contact, sticking friction) or
// clamped at a known force (separated contact: 0; slipping friction: -sign(slip) times the
// bound); the free rows are solved exactly given the clamped ones, then rows whose law is
// violated switch, and slipping bounds are refreshed from the new lateral forces, until nothing
// changes. Sets without friction rows go to the generic ConstraintSolver unchanged.

#include <Eigen/Core>
#include <vector>

#include "common/constraints/constraint_solver.h"

namespace nsim {

/// An axial friction row: a one-row bilateral group of the set whose multiplier is bounded by
/// mu |(lambda[lateral_rows[0]], lambda[lateral_rows[1]])| + stiction.
struct AxialFrictionRow {
  int row = -1;
  int lateral_rows[2] = {-1, -1};
  double mu = 0.0;        ///< Coulomb coefficient (-), >= 0
  double stiction = 0.0;  ///< constant part of the bound (N), >= 0
};

/// Settings of NeedleConstraintSolver.
struct NeedleSolverConfig {
  /// Row laws are met to this position tolerance (m): slip below it counts as stick.
  double position_tolerance = 1e-10;
  /// Relative force tolerance (-): a force exceeds its bound when by more than this times
  /// (1 + the largest |lambda|) N.
  double force_tolerance = 1e-9;
  /// Active-set iterations before giving up (report.converged = false).
  int max_iterations = 100;
  /// Diagonal regularization of the free block: this times its largest diagonal entry; keeps
  /// redundant rows (a point held twice) solvable (-).
  double regularization = 1e-12;
  /// Settings of the generic solver used for assembly and for sets without friction rows.
  ConstraintSolverConfig generic;
};

/// Outcome of NeedleConstraintSolver::Solve.
struct NeedleSolveReport {
  ConstraintSolveReport generic;  ///< the generic solver's report when it solved the set
  bool used_generic = false;      ///< no friction rows: solved by ConstraintSolver
  int iterations = 0;             ///< active-set iterations
  bool converged = true;
  int num_slipping = 0;           ///< friction rows at their bound
  int num_separated = 0;          ///< unilateral rows at zero force
  double max_violation = 0.0;     ///< largest law violation after the solve (m)
};

class NeedleConstraintSolver {
 public:
  explicit NeedleConstraintSolver(const NeedleSolverConfig& config = {});

  /// Solves `set` (bilateral and unilateral groups; kFriction groups only without friction
  /// rows) with the given axial friction rows, and hands the corrections to the set's bodies.
  NeedleSolveReport Solve(const ConstraintSet& set, const std::vector<AxialFrictionRow>& friction);

  /// Multipliers of the last solve, one per row (N).
  const Eigen::VectorXd& lambda() const { return lambda_; }
  /// Row values after the correction, delta_free + W lambda (m).
  Eigen::VectorXd CalcRowValues() const;
  /// The generic solver (W, delta_free, compliance cache of the last assembly).
  const ConstraintSolver& generic() const { return generic_; }

 private:
  NeedleSolverConfig config_;
  ConstraintSolver generic_;
  Eigen::VectorXd lambda_;
  std::vector<Eigen::Matrix3Xd> dx_;
};

}  // namespace nsim
