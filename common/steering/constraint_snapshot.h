#pragma once
// The constraint problem of one inverse-simulation step, frozen for the Jacobian's perturbation
// solves (thesis eq. 3.6 / A.2; DESIGN.md "Speed").
//
// After the free motion and the assembly of a step, the compliances C_b = h^2 A_b^-1 of the
// compliant bodies and their free positions are fixed. A perturbation of the needle's pose
// changes
//  - the needle's kinematic constraint points (a rigid needle: they move rigidly with it) and
//    the directions of the rows that measure them (they turn with it);
//  - the free positions of a body whose free motion depends on the needle's base pose (a
//    flexible needle clamped to the flange): they move by S_b [dp; dtheta], the body's
//    first-order sensitivity to its base pose (BeamNeedleBody::CalcFreeMotionSensitivity; exact
//    for translations), with dp = p' - p and dtheta = log(R' R^T) from the captured base pose.
// With the point blocks
//     G_ab = N_a C_b N_b^T   (3 x 3, m/N)     for two body points a, b of the same body
// (zero across bodies: G is block-diagonal by body), each row i = sum_t d_t . x(p_t) - target_i
// has the compliance row h_i = [d_t on point a_t] and
//     W' = H' G H'^T,   delta' = H' x_free' + (kinematic terms at the moved points) - target,
// a dense solve of #rows unknowns (a few tens): the perturbation costs microseconds, not a FEM
// step. The corrected position of any probe material point q of body b follows from the same
// columns,  x(q) = N_q x_free' + sum_i lambda_i sum_t (N_q C_b N_{a_t}^T) d_t.
// Exactness: for a perturbation that leaves the rows' directions unchanged (pure translations),
// the result equals a full re-simulation of the step with the perturbed needle (same free
// motion, same W); for rotations too, when the full step would turn its rows by the same
// rotation (a rigid needle).
// Approximation with a flexible needle: the coupling takes the directions of the rows that
// measure the beam from the beam's free shape (its tangents and free tip frame), which a
// perturbation moves. The snapshot turns those rows with the base, by R' R^T (SnapshotBody::
// rows_turn), which is what the free shape does when it follows its base rigidly; it does not
// follow the part of S that bends the beam (its inertia lag, O(m / (h^2 k)) of the base's
// motion). The perturbed solve therefore equals a full re-simulation for translations when the
// beam's free shape translates with its base, and agrees to O(|dtheta|^2) for rotations in
// that case; otherwise the rows' direction error is the lag's (~3 % of the perturbation's
// turn for the default scenario's 13 cm steel needle at h = 20 ms) times the axial slip of
// the needle over the step.
//
// Soft rows (ConstraintRow::softness) keep their softness: W'_ii is scaled as in the step.
// The multipliers come from the constraint solver's SolveConstraintLaws (constraint_solver.h)
// with the captured solver's settings: bilateral groups alone by the direct LDLT solve (as the
// step itself), with unilateral (contact) or axial friction rows by the active set (or the
// axial friction rows held at the step's forces: set_hold_friction). Coulomb
// friction groups are not supported (Capture throws): the inverse model has none.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "common/constraints/constraint_set.h"
#include "common/constraints/constraint_solver.h"

namespace nsim {

/// A material point of a captured body whose corrected position is wanted: sum_k w_k x_k.
struct SnapshotProbe {
  std::vector<int> nodes;
  std::vector<double> weights;
};

/// A compliant body of the captured set.
struct SnapshotBody {
  int body = -1;                      ///< index in the set's bodies
  std::vector<SnapshotProbe> probes;  ///< its material points Solve reports
  /// Sensitivity of its free node positions to the needle's base pose, 3 #nodes x 6 (m/m,
  /// m/rad; columns dp, then dtheta of R' = exp(dtheta) R, world axes), or empty: the free
  /// positions do not depend on the needle's pose.
  Eigen::MatrixXd free_sensitivity;
  /// Rows with a point of this body turn with the needle's rotation R' R^T (a body that moves
  /// with the needle, a beam clamped to it), unless they belong to a unilateral group.
  bool rows_turn = false;
};

/// Scratch space of Solve, so that a const snapshot can be solved without allocating state in
/// it (one workspace per thread).
struct SnapshotWorkspace {
  Eigen::MatrixXd H;        // rows x 3B
  Eigen::MatrixXd HG;       // rows x 3B
  Eigen::MatrixXd W;        // rows x rows
  Eigen::VectorXd delta;    // rows
  Eigen::VectorXd lambda;   // rows
  Eigen::VectorXd force;    // 3B
  Eigen::VectorXd shift;    // 3B: free-position shifts of the body points (m)
  ConstraintWorkspace solver;
  /// The resultant of the constraint forces on the needle's moving kinematic points after
  /// Solve (world, N): each row's multiplier times its needle terms' directions. Zero for a
  /// needle that is a body (a beam) rather than kinematic points.
  Eigen::Vector3d needle_force = Eigen::Vector3d::Zero();
};

class ConstraintSnapshot {
 public:
  /// Captures the problem of `set` after `solver.Assemble(set)` (and before the corrections are
  /// committed): rows, groups, free positions and the compliance columns of the body points of
  /// body `body` (the only compliant body allowed: rows with points on other bodies throw
  /// InputError). Kinematic points with moves_with_needle[p] != 0 (size num_points) move with
  /// the needle whose pose at the step end is X_WN; rows containing such a point turn with the
  /// needle unless they belong to a unilateral group (a contact normal belongs to the tissue).
  /// probes: material points of the body whose corrected positions Solve reports.
  void Capture(const ConstraintSet& set, const ConstraintSolver& solver, int body,
               const std::vector<char>& moves_with_needle, const Eigen::Isometry3d& X_WN,
               const std::vector<SnapshotProbe>& probes);

  /// The same for several compliant bodies (rows on a body not listed throw InputError), each
  /// with its probes and optionally the sensitivity of its free positions to the needle's base
  /// pose X_WN (see the file comment). The probes are numbered body after body.
  void Capture(const ConstraintSet& set, const ConstraintSolver& solver,
               const std::vector<SnapshotBody>& bodies,
               const std::vector<char>& moves_with_needle, const Eigen::Isometry3d& X_WN);

  /// Held friction (for the Captures that follow): the axial friction rows (kAxialFriction)
  /// keep the forces of the captured step's solve (solver.lambda(), in their captured
  /// directions) instead of being solved again: their corrections join the free motion and
  /// the rows leave the problem. A perturbed needle then slides through the tissue with the
  /// step's friction load on it, as a needle that keeps moving does (kinetic friction), where
  /// the solved law would let a small perturbation stick and drag the tissue along: the
  /// Jacobian of an insertion would then see no axial motion of the tip against its target.
  /// The unperturbed solve still reproduces the committed step (the other rows' multipliers
  /// are the step's, given the held forces); perturbed solves no longer equal a re-simulation
  /// of the step when a friction row would have switched between stick and slip.
  void set_hold_friction(bool hold) { hold_friction_ = hold; }

  /// Solves the captured step with the needle at X_WN_new (end of step) and writes the probes'
  /// corrected positions (m, world), one per probe, and the multipliers (N) into `workspace`.
  /// The report says whether the solve converged (see constraint_solver.h).
  ConstraintSolveReport Solve(const Eigen::Isometry3d& X_WN_new, SnapshotWorkspace& workspace,
                              std::vector<Eigen::Vector3d>* probe_positions) const;

  /// The stiffness of the captured problem against a rigid translation of the needle's moving
  /// kinematic points, at the captured pose: K = D^T W^-1 D (N/m, symmetric), D the rows'
  /// needle directions, so that a translation dp changes the needle's resultant force by
  /// -K dp (the rows solved as bilateral, the softness applied as in Solve). Zero without
  /// moving points or rows.
  Eigen::Matrix3d CalcNeedleTranslationStiffness(SnapshotWorkspace& workspace) const;

  int num_rows() const { return static_cast<int>(rows_.size()); }
  int num_body_points() const { return num_body_points_; }
  int num_probes() const { return static_cast<int>(probe_free_.size()); }
  /// Free (uncorrected) position of probe k (m).
  const Eigen::Vector3d& probe_free_position(int k) const { return probe_free_[k]; }
  /// Needle pose the snapshot was captured with.
  const Eigen::Isometry3d& X_WN() const { return X_WN_; }

 private:
  struct Term {
    int body_point = -1;  // index among the captured body points, or -1: kinematic
    Eigen::Vector3d direction = Eigen::Vector3d::Zero();
    Eigen::Vector3d p_kinematic = Eigen::Vector3d::Zero();  // kinematic end position (W, m)
    Eigen::Vector3d p_N = Eigen::Vector3d::Zero();          // same in the needle frame (moving)
    bool moving = false;
  };
  struct Row {
    int first_term = 0, num_terms = 0;
    double target = 0.0;
    bool turns = false;  // directions turn with the needle
    double softness = 0.0;  // ConstraintRow::softness
    double compliance = 0.0;  // ConstraintRow::compliance (m/N)
  };

  std::vector<Term> terms_;
  std::vector<Row> rows_;
  std::vector<ConstraintGroup> groups_;  // the set's laws
  ConstraintSolverConfig config_;        // the captured solver's, direct or the active set
  int num_body_points_ = 0;
  std::vector<Eigen::Vector3d> free_;  // free positions of the body points (m)
  Eigen::MatrixXd G_;                  // 3B x 3B point blocks (m/N), zero across bodies
  Eigen::MatrixXd P_;                  // 3 #probes x 3B: N_q C N_a^T (m/N)
  std::vector<Eigen::Vector3d> probe_free_;
  // free-position sensitivities to the base pose (3B x 6, 3 #probes x 6); empty: none
  Eigen::MatrixXd point_sensitivity_, probe_sensitivity_;
  Eigen::Isometry3d X_WN_ = Eigen::Isometry3d::Identity();
  bool hold_friction_ = false;

  // the held-friction transformation of the captured problem (set_hold_friction)
  void HoldFrictionForces(const Eigen::VectorXd& lambda);
};

}  // namespace nsim
