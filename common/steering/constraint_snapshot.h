#pragma once
// The constraint problem of one inverse-simulation step, frozen for the Jacobian's perturbation
// solves (thesis eq. 3.6 / A.2; DESIGN.md "Speed").
//
// After the free motion and the assembly of a step, the tissue's compliance C = h^2 A^-1 and
// its free positions are fixed. A perturbation of the rigid needle's pose changes only the
// needle's kinematic constraint points (they move rigidly with the needle) and the directions of
// the rows that measure the needle (they turn with it). With the point blocks
//     G_ab = N_a C N_b^T   (3 x 3, m/N)     for every pair of body points a, b of the set,
// each row i = sum_t d_t . x(p_t) - target_i has the compliance row h_i = [d_t on point a_t] and
//     W' = H' G H'^T,   delta' = H' x_free + (kinematic terms at the moved points) - target,
// a dense solve of #rows unknowns (a few tens): the perturbation costs microseconds, not a FEM
// step. The corrected position of any probe material point q follows from the same columns,
//     x(q) = N_q x_free + sum_i lambda_i sum_t (N_q C N_{a_t}^T) d_t.
// Exactness: for a perturbation that leaves the rows' directions unchanged (pure translations),
// the result equals a full re-simulation of the step with the perturbed needle (same free motion,
// same W); for rotations too, when the full step would turn its rows by the same rotation.
//
// The multipliers come from the constraint solver's SolveConstraintLaws (constraint_solver.h)
// with the captured solver's settings: bilateral groups alone by the direct LDLT solve (as the
// step itself), with unilateral (contact) or axial friction rows by the active set. Coulomb
// friction groups are not supported (Capture throws): the inverse model has none.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "common/constraints/constraint_set.h"
#include "common/constraints/constraint_solver.h"

namespace nsim {

/// A material point of the captured body whose corrected position is wanted: sum_k w_k x_k.
struct SnapshotProbe {
  std::vector<int> nodes;
  std::vector<double> weights;
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
  ConstraintWorkspace solver;
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

  /// Solves the captured step with the needle at X_WN_new (end of step) and writes the probes'
  /// corrected positions (m, world), one per probe, and the multipliers (N) into `workspace`.
  /// The report says whether the solve converged (see constraint_solver.h).
  ConstraintSolveReport Solve(const Eigen::Isometry3d& X_WN_new, SnapshotWorkspace& workspace,
                              std::vector<Eigen::Vector3d>* probe_positions) const;

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
  };

  std::vector<Term> terms_;
  std::vector<Row> rows_;
  std::vector<ConstraintGroup> groups_;  // the set's laws
  ConstraintSolverConfig config_;        // the captured solver's, direct or the active set
  int num_body_points_ = 0;
  std::vector<Eigen::Vector3d> free_;  // free positions of the body points (m)
  Eigen::MatrixXd G_;                  // 3B x 3B point blocks (m/N)
  Eigen::MatrixXd P_;                  // 3 #probes x 3B: N_q C N_a^T (m/N)
  std::vector<Eigen::Vector3d> probe_free_;
  Eigen::Isometry3d X_WN_ = Eigen::Isometry3d::Identity();
};

}  // namespace nsim
