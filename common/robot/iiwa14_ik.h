#pragma once
// Constraint-based inverse kinematics of the redundant iiwa (thesis appendix A): find joint
// angles q within the position limits with X_WT(q) = X_WT_target.

#include <Eigen/Geometry>
#include <cstdint>

#include "common/robot/iiwa14.h"

namespace nsim {

/// Settings of the IK solver. SI units.
struct Iiwa14IkConfig {
  double position_tolerance = 1e-6;     ///< success: |p_target - p_WT| <= this (m), > 0
  double orientation_tolerance = 1e-6;  ///< success: angle(R_target, R_WT) <= this (rad), > 0
  int max_iterations = 100;             ///< damped Gauss-Newton iterations per attempt, >= 1
  int max_restarts = 20;                ///< extra attempts from random in-limit seeds, >= 0
  double initial_damping = 1e-3;        ///< Levenberg-Marquardt mu (m^2 ~ rad^2), > 0
  double max_joint_step = 0.5;          ///< trust region: max |dq_i| per iteration (rad), > 0
  double null_space_gain = 0.1;  ///< fraction of (q_mid - q) per iteration, in [0, 1], far phase
  uint64_t random_seed = 7;      ///< seed of the restart sequence (deterministic)

  /// Throws InputError naming the first invalid field.
  void Validate() const;
};

/// Outcome of one IK solve. Never a crash: an unreachable target gives success = false with
/// the residual of the best attempt.
struct Iiwa14IkResult {
  bool success = false;            ///< both tolerances met
  Vector7d q = Vector7d::Zero();   ///< best joints found, always within the limits (rad)
  double position_error = 0.0;     ///< |p_target - p_WT(q)| (m)
  double orientation_error = 0.0;  ///< angle(R_target, R_WT(q)) (rad)
  int iterations = 0;              ///< iterations over all attempts
  int restarts = 0;                ///< attempts after the first
};

/// Levenberg-Marquardt (damped least squares) IK with joint limits as inequality constraints,
/// solved by an active set on the bounds, plus a null-space pull toward mid-range:
///   e = [p_target - p_WT; Log(R_target R_WT^T)]   (world-aligned, rows [linear; angular])
///   A = [Jv; JrInv(e_o) Jw]  so that de = -A dq to first order (JrInv: exact SO(3) term)
///   dq = A_F^T (A_F A_F^T + mu I)^-1 e + N_F k (q_mid - q)
/// where F is the free set: a joint on a bound whose step would push it out is fixed (its
/// column removed) and the step recomputed, until consistent; N_F is the exact null-space
/// projector of A_F (SVD), applied while |e| > 1e-3 (so the last iterations are pure damped
/// Gauss-Newton and converge quadratically). The step is capped at max_joint_step, q is projected
/// onto the bounds, and accepted only if |e| decreases (mu / 10), else mu * 10 (first without the
/// null-space term). An attempt ends on success, on mu > 1e6 (a local minimum) or after
/// max_iterations; then restarts from the mid-range and from seeded random joints. Every
/// iterate is within the limits. Deterministic for a given config.
class Iiwa14InverseKinematics {
 public:
  /// `model` must outlive the solver. Validates `config` (throws InputError).
  Iiwa14InverseKinematics(const Iiwa14Model& model, const Iiwa14IkConfig& config);

  const Iiwa14IkConfig& config() const { return config_; }

  /// Joints placing the tool T at X_WT_target, starting from q_seed (rad; clamped into the
  /// limits, mid-range if non-finite). A non-finite or non-rigid target returns success =
  /// false with infinite errors. No heap allocation.
  Iiwa14IkResult Solve(const Eigen::Isometry3d& X_WT_target, const Vector7d& q_seed) const;

 private:
  // one damped Gauss-Newton descent from q0; returns true on success
  bool Descend(const Eigen::Isometry3d& X_WT_target, const Vector7d& q0,
               Iiwa14IkResult* attempt) const;

  const Iiwa14Model& model_;
  Iiwa14IkConfig config_;
};

}  // namespace nsim
