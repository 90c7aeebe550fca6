#pragma once
// Constraint resolution of one step (thesis §3.1, eq. 3.2; Duriez 2009, Courtecuisse 2014), the
// one solver of the simulator: the patient scene and the needle insertion (needle coupling,
// rib contacts), the inverse model's step, and its frozen-step perturbation solves
// (common/steering/constraint_snapshot.h, which builds W and delta itself) all end in
// SolveConstraintLaws below.
//  1. the bodies have done their free motion (x_free, v_free);
//  2. delta_free = H x_free - target (m) and W = sum_b H_b C_b H_b^T (m/N), C_b = h^2 A_b^-1,
//     with the diagonal of a soft row scaled by 1 + its softness (constraint_set.h: the row's
//     own compliance in series with the bodies');
//  3. lambda (N) such that the end-of-step row values r = delta_free + W lambda obey the laws of
//     their groups (constraint_set.h):
//       bilateral        r = 0, lambda free;
//       unilateral       r >= 0, lambda >= 0, r lambda = 0;
//       Coulomb friction normal row as unilateral; |lambda_t| <= mu lambda_n, zero tangential
//                        slip r_t inside the cone, slip opposed by lambda_t on its boundary;
//       axial friction   (the needle's) |lambda| <= b = mu |lambda_normal group| + stiction;
//                        r = 0 inside the bound, at the bound lambda opposes the slip r;
//  4. correction dx_b = C_b H_b^T lambda, dv_b = dx_b / h, handed to every body.
// Everything is at position level on end-of-step positions (see constraint_body.h): lambda is
// the constraint force held constant over the step (impulse h lambda).
//
// Methods (ConstraintMethod), all on the same W, delta and laws:
//  - active set on direct LDLT solves, for bilateral, unilateral and axial friction rows: every
//    row is free (bilateral, a pushing contact, sticking axial friction) or clamped at a known
//    force (degenerate: 0, see below; separated contact: 0; slipping axial friction:
//    -sign(slip) times its bound). The free rows are solved exactly given the clamped ones;
//    then rows whose law is violated by more than the tolerances switch and slipping bounds
//    are refreshed from the new normal forces, until nothing changes (exact once it stops,
//    but for the regularization). Every free block is factorized as W_ff + eps I with eps =
//    active_set_regularization (1e-12) times its largest diagonal entry, so that redundant
//    rows (a point held twice) cost no second factorization (the needle coupling's solver
//    did so: its results are kept bit for bit).
//  - direct, when every row is bilateral: the same free-rows LDLT of W, regularized only when
//    singular: when its smallest pivot is below singular_pivot_ratio (1e-12) times its largest
//    diagonal entry it is redone as (W + eps I), eps = regularization (1e-10) times that entry
//    (a least-squares compromise for inconsistent redundant rows; report.regularized).
//  - projected block Gauss-Seidel (PGS), for every law (the only one for Coulomb cones).
// Rows with W_ii <= 1e-14 max W_jj (no compliant point) are degenerate: lambda = 0, counted.
//
// Convergence (ConstraintSolverConfig): PGS stops when the natural-map residual is <=
// pgs_tolerance (1e-10 m) or after pgs_max_iterations (1000) sweeps; the active set stops when
// no row switches (thresholds position_tolerance 1e-10 m and force_tolerance 1e-9 (1 + max
// |lambda|) N) or after active_set_max_iterations (100) solves. A solve that stops on its cap,
// or whose lambda is not finite, reports converged = false, with its residual and violation.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <vector>

#include "common/constraints/compliance.h"
#include "common/constraints/constraint_set.h"

namespace nsim {

/// How the multipliers are found.
enum class ConstraintMethod {
  kAuto,       ///< direct when every group is bilateral; else PGS when a group is a Coulomb
               ///< cone; else the active set when a group is axial friction (the needle
               ///< coupling); else (contacts without friction) PGS
  kDirect,     ///< LDLT of W; only valid when every group is bilateral
  kActiveSet,  ///< active set on LDLT solves; bilateral, unilateral and axial friction groups
  kPgs,        ///< projected block Gauss-Seidel, for any law
};

/// Solver settings.
struct ConstraintSolverConfig {
  ConstraintMethod method = ConstraintMethod::kAuto;
  /// PGS stops when the largest row residual (natural map, m; see ConstraintSolveReport)
  /// is <= this.
  double pgs_tolerance = 1e-10;
  /// PGS gives up after this many sweeps and reports converged = false.
  int pgs_max_iterations = 1000;
  /// Active set: a contact or a slipping axial row switches when its row value is wrong by more
  /// than this (m): penetration, or slip along its friction force.
  double position_tolerance = 1e-10;
  /// Active set: a force leaves its bound when by more than this times (1 + the largest
  /// |lambda|) N (-): a pulling contact, sticking axial friction above its bound.
  double force_tolerance = 1e-9;
  /// The active set gives up after this many solves and reports converged = false.
  int active_set_max_iterations = 100;
  /// Active set: every free block W_ff is factorized with this times its largest diagonal
  /// entry added to its diagonal (-): keeps redundant rows solvable in one factorization.
  double active_set_regularization = 1e-12;
  /// Direct: W counts as singular when its smallest LDLT pivot is below this times its largest
  /// diagonal entry (redundant rows, e.g. a point held twice) ...
  double singular_pivot_ratio = 1e-12;
  /// ... and is then solved as (W + eps I) lambda = -delta with eps = this times the largest
  /// diagonal entry of W (a least-squares compromise for inconsistent redundant rows).
  double regularization = 1e-10;
  /// Slip-direction fixed-point iterations inside one PGS friction-cone update.
  int friction_inner_iterations = 8;
};

/// Outcome of one resolution.
struct ConstraintSolveReport {
  ConstraintMethod method = ConstraintMethod::kAuto;  ///< the method actually used
  int num_rows = 0;
  int iterations = 0;        ///< PGS sweeps, or LDLT solves of the active set (1 for direct)
  bool converged = true;     ///< met its stopping rule (see the file comment), lambda finite
  bool regularized = false;  ///< direct: W was singular and regularized
  /// Largest natural-map residual over the rows (m): bilateral |r|; unilateral
  /// |min(W_ii lambda, r)|; friction tangents w_t |lambda_t - P_cone(lambda_t - r_t / w_t)|;
  /// axial friction W_ii |lambda - P_[-b,b](lambda - r / W_ii)|. Groups with a degenerate row
  /// are left out.
  double residual = 0.0;
  /// Largest violation of the position laws after correction (m): bilateral |r|, unilateral
  /// and friction-normal max(0, -r), axial friction |r| inside its bound and the slip along
  /// its force, max(0, sign(lambda) r), at the bound.
  double max_violation = 0.0;
  int num_degenerate_rows = 0;  ///< rows with W_ii <= 0 (no compliant point), left at 0
  /// Friction at its bound: axial rows with |lambda| >= b - force tolerance, Coulomb contacts
  /// pushing with |lambda_t| >= mu lambda_n - force tolerance.
  int num_slipping = 0;
  int num_separated = 0;  ///< unilateral and friction-contact normals with lambda <= 0
};

/// Scratch space of SolveConstraintLaws: reuse one per thread to avoid allocating.
struct ConstraintWorkspace {
  Eigen::VectorXd r;            // row values delta + W lambda (m)
  std::vector<char> clamped;    // active set: row held at clamp_value
  Eigen::VectorXd clamp_value;  // (N)
  std::vector<char> degenerate;
  std::vector<int> free_rows, clamped_nonzero;
  Eigen::MatrixXd W_free;
  Eigen::VectorXd rhs, solution;
  Eigen::LDLT<Eigen::MatrixXd> ldlt;
  std::vector<Eigen::Matrix3d> block_inverse;  // PGS: pseudo-inverse of each group's block
  std::vector<char> active;                    // PGS: groups without a degenerate row
};

/// Finds lambda (N, one per row) for the compliance W (m/N), the free row values delta (m) and
/// the groups' laws (contiguous groups covering every row, as ConstraintSet makes them), with
/// config's method. The only multiplier solve of the simulator (see the file comment).
/// InputError when a row is ungrouped or the method cannot handle a law.
ConstraintSolveReport SolveConstraintLaws(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta,
                                          const std::vector<ConstraintGroup>& groups,
                                          const ConstraintSolverConfig& config,
                                          ConstraintWorkspace& workspace, Eigen::VectorXd& lambda);

/// W_ii = W_ii (1 + rows[i].softness) + rows[i].compliance for every soft row (the rows' own
/// compliance, constraint_set.h); W is the bodies' compliance of those rows, rows.size()
/// square. Row: ConstraintRow, or a copy of it with softness and compliance members
/// (ConstraintSnapshot's).
template <typename Row>
void ApplyRowSoftness(const std::vector<Row>& rows, Eigen::MatrixXd& W) {
  for (int i = 0; i < static_cast<int>(rows.size()); ++i) {
    if (rows[i].softness > 0.0) W(i, i) *= 1.0 + rows[i].softness;
    if (rows[i].compliance > 0.0) W(i, i) += rows[i].compliance;
  }
}

/// Solves the constraints of a step and applies the corrections. Keeps W, delta, lambda and
/// the compliance cache between calls; reuse one object across steps.
class ConstraintSolver {
 public:
  explicit ConstraintSolver(const ConstraintSolverConfig& config = {});

  /// Assemble + SolveMultipliers + ApplyCorrections.
  ConstraintSolveReport Solve(const ConstraintSet& set);

  /// Builds W (m/N, the soft rows' own compliance included) and delta_free (m) for `set` from
  /// the bodies' free positions.
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
  ConstraintSolverConfig config_;
  ComplianceAssembler compliance_;
  Eigen::MatrixXd W_;
  Eigen::VectorXd delta_;
  Eigen::VectorXd lambda_;
  ConstraintWorkspace workspace_;
  std::vector<Eigen::Matrix3Xd> dx_;
};

}  // namespace nsim
