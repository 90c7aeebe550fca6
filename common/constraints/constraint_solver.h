#pragma once
// Constraint resolution of one step (thesis §3.1, eq. 3.2; Duriez 2009, Courtecuisse 2014):
//  1. the bodies have done their free motion (x_free, v_free);
//  2. delta_free = H x_free - target (m) and W = sum_b H_b C_b H_b^T (m/N), C_b = h^2 A_b^-1;
//  3. lambda (N) such that the end-of-step row values r = delta_free + W lambda obey the laws:
//     all-bilateral sets by a direct LDLT of W; otherwise projected (block) Gauss-Seidel;
//  4. correction dx_b = C_b H_b^T lambda, dv_b = dx_b / h, handed to every body.
// Everything is at position level on end-of-step positions (see constraint_body.h): lambda is
// the constraint force held constant over the step (impulse h lambda).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/constraints/compliance.h"
#include "common/constraints/constraint_set.h"

namespace nsim {

/// How the multipliers are found.
enum class ConstraintMethod {
  kAuto,    ///< direct when every group is bilateral, projected Gauss-Seidel otherwise
  kDirect,  ///< LDLT of W; only valid when every group is bilateral
  kPgs,     ///< projected block Gauss-Seidel, for any law
};

/// Solver settings.
struct ConstraintSolverConfig {
  ConstraintMethod method = ConstraintMethod::kAuto;
  /// PGS stops when the largest row residual (natural map, m; see ConstraintSolveReport)
  /// is <= this.
  double pgs_tolerance = 1e-10;
  /// PGS gives up after this many sweeps and reports converged = false.
  int pgs_max_iterations = 1000;
  /// Direct solve: W counts as singular when its smallest LDLT pivot is below this times its
  /// largest diagonal entry (redundant rows, e.g. a point held twice) ...
  double singular_pivot_ratio = 1e-12;
  /// ... and is then solved as (W + eps I) lambda = -delta with eps = this times the largest
  /// diagonal entry of W (a least-squares compromise for inconsistent redundant rows).
  double regularization = 1e-10;
  /// Slip-direction fixed-point iterations inside one friction block update.
  int friction_inner_iterations = 8;
};

/// Outcome of one resolution.
struct ConstraintSolveReport {
  ConstraintMethod method = ConstraintMethod::kAuto;  ///< the method actually used
  int num_rows = 0;
  int iterations = 0;        ///< PGS sweeps (0 for direct)
  bool converged = true;     ///< PGS met the tolerance; direct: always true
  bool regularized = false;  ///< direct: W was singular and regularized
  /// Largest natural-map residual over the rows (m): bilateral |r|; unilateral
  /// |min(W_ii lambda, r)|; friction tangents w_t |lambda_t - P_cone(lambda_t - r_t / w_t)|.
  double residual = 0.0;
  /// Largest violation of the position laws after correction (m): bilateral |r|, unilateral
  /// and friction-normal max(0, -r).
  double max_violation = 0.0;
  int num_degenerate_rows = 0;  ///< rows with W_ii <= 0 (no compliant point), left at 0
};

/// Solves the constraints of a step and applies the corrections. Keeps W, delta, lambda and
/// the compliance cache between calls; reuse one object across steps.
class ConstraintSolver {
 public:
  explicit ConstraintSolver(const ConstraintSolverConfig& config = {});

  /// Assemble + SolveMultipliers + ApplyCorrections.
  ConstraintSolveReport Solve(const ConstraintSet& set);

  /// Builds W (m/N) and delta_free (m) for `set` from the bodies' free positions.
  void Assemble(const ConstraintSet& set);
  /// Finds lambda (N) for the W and delta of the last Assemble (set must be the same one; its
  /// kinematic points and targets may have changed if RecomputeDelta was called).
  ConstraintSolveReport SolveMultipliers(const ConstraintSet& set);
  /// Recomputes delta_free only (W unchanged): for re-solving after moving kinematic points or
  /// targets of the same rows, e.g. the perturbations of the inverse simulation.
  void RecomputeDelta(const ConstraintSet& set);
  /// Hands dx_b = C_b H_b^T lambda to every body of the set.
  void ApplyCorrections(const ConstraintSet& set);

  /// Multipliers of the last solve, one per row (N).
  const Eigen::VectorXd& lambda() const { return lambda_; }
  /// Compliance of the last Assemble (rows x rows, m/N).
  const Eigen::MatrixXd& W() const { return W_; }
  /// Row values after the free motion (m).
  const Eigen::VectorXd& delta_free() const { return delta_; }
  /// Row values after correction, delta_free + W lambda (m).
  Eigen::VectorXd CalcRowValues() const { return delta_ + W_ * lambda_; }
  /// Force applied to point p by the rows of the last solve, sum_t d_t lambda (N); for a
  /// kinematic point this is the force the tissue exerts on the prescribed object.
  Eigen::Vector3d CalcPointForce(const ConstraintSet& set, int p) const;
  /// Position corrections of the last ApplyCorrections (3 x n_b per body, m).
  const std::vector<Eigen::Matrix3Xd>& corrections() const { return dx_; }

  const ComplianceAssembler& compliance() const { return compliance_; }
  ComplianceAssembler& compliance() { return compliance_; }
  const ConstraintSolverConfig& config() const { return config_; }

 private:
  void SolveDirect(ConstraintSolveReport& report);
  void SolvePgs(const ConstraintSet& set, ConstraintSolveReport& report);
  double CalcResidual(const ConstraintSet& set, const Eigen::VectorXd& r) const;
  double CalcViolation(const ConstraintSet& set, const Eigen::VectorXd& r) const;

  ConstraintSolverConfig config_;
  ComplianceAssembler compliance_;
  Eigen::MatrixXd W_;
  Eigen::VectorXd delta_;
  Eigen::VectorXd lambda_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  std::vector<Eigen::Matrix3Xd> dx_;
  // pgs scratch: per group inverse of its diagonal block
  std::vector<Eigen::Matrix3d> block_inverse_;
};

}  // namespace nsim
