#pragma once
// The interface between the constraint solver and one simulated body (thesis §3.1, eq. 3.2;
// Duriez 2009, Courtecuisse 2014): the body first does its free motion, the solver then asks it
// for its compliance on a few sparse right-hand sides and hands back a correction.
//
// Units and time-stepping convention (used by everything in common/constraints):
// a body integrates with linearized implicit Euler, A dv = b with A = M + h C + h^2 K (kg),
// x_end = x_start + h (v_start + dv). A constraint force f (N), constant over the step, adds
// h f to the right-hand side, so it moves the end-of-step positions by
//     dx = h^2 A^-1 f =: C f,        dv = dx / h,
// where C = h^2 A^-1 (m/N) is the body's *position compliance* for the step. All constraint rows
// are therefore written at position level on end-of-step positions: the solver sees
// delta_free = H x_free - target (m), W = sum_b H_b C_b H_b^T (m/N), and solves for forces
// lambda (N) such that delta_free + W lambda satisfies the row laws.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>

namespace nsim {

/// A deformable (or particle) body taking part in constraints. Degrees of freedom are the node
/// positions, ordered node-major: dof 3 i + c is coordinate c of node i. Nodes the body holds
/// fixed or prescribes have zero rows and columns in C.
class ConstraintBody {
 public:
  ConstraintBody();
  virtual ~ConstraintBody() = default;
  ConstraintBody(const ConstraintBody&) = delete;
  ConstraintBody& operator=(const ConstraintBody&) = delete;

  /// Number of nodes n (the body has 3 n dofs).
  virtual int num_nodes() const = 0;

  /// Node positions at the start of the current step (m), 3 x n.
  virtual const Eigen::Matrix3Xd& start_positions() const = 0;

  /// Node positions after the free motion of the current step, without constraint forces (m),
  /// 3 x n. Valid between the body's free-motion solve and the end of the step.
  virtual const Eigen::Matrix3Xd& free_positions() const = 0;

  /// displacements = C forces with C = h^2 A^-1 (m/N) of the current step, for k right-hand
  /// sides at once. forces: 3n x k (N), usually a few nonzeros per column; displacements is
  /// resized to 3n x k (m). Const: must not change the body's state.
  virtual void ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                               Eigen::MatrixXd& displacements) const = 0;

  /// A number that changes whenever C changes (new factorization, new step size, new
  /// stiffness); two calls returning the same value promise the same C, which lets the solver
  /// reuse C columns of constraint points that persist between steps (DESIGN.md "Speed").
  /// A body whose C changes every step returns a new value every step.
  virtual std::uint64_t compliance_version() const = 0;

  /// Adds the constraint correction to the end-of-step state: x_end += dx (m), v_end += dx / h.
  /// dx: 3 x n. Called once per step by the solver (possibly with a zero dx).
  virtual void ApplyCorrection(const Eigen::Matrix3Xd& dx) = 0;

  /// Process-wide unique identity of this body object (never reused), for caches.
  std::uint64_t uid() const { return uid_; }

 private:
  std::uint64_t uid_;
};

}  // namespace nsim
