#pragma once
// Joint-space motion of the iiwa toward commanded joint angles under the position, velocity and
// acceleration limits of Iiwa14Config (the joint-space counterpart of CartesianRobot, used when
// the controller commands joints, thesis eq. A.3).

#include "common/robot/iiwa14.h"

namespace nsim {

/// Mutable joint state. Cheap to copy.
struct JointState {
  Vector7d q = Vector7d::Zero();   ///< joint angles (rad)
  Vector7d qd = Vector7d::Zero();  ///< joint rates (rad/s)
};

/// What happened to one joint command.
struct JointStepReport {
  bool accepted = true;            ///< false: the command had a non-finite entry; robot braked
  bool clamped_to_limits = false;  ///< the command was outside the position limits
  bool rate_limited = false;       ///< some joint did not reach its (clamped) command this step
  double max_error = 0.0;          ///< max |q_cmd - q| over joints after the step (rad)
};

/// Moves each joint independently toward its command, clamped into the position limits, with
/// the discrete braking law of StepVelocityTowards() under that joint's velocity and
/// acceleration limits. q never leaves the limits: if a command that moves while a joint runs
/// toward a limit would carry it past, the joint is stopped on the limit (the one case where the
/// acceleration limit yields to the position limit).
class JointInterpolator {
 public:
  /// Uses the limits of `model`, which must outlive the interpolator.
  explicit JointInterpolator(const Iiwa14Model& model) : model_(model) {}

  /// A state at rest at q (rad). Throws InputError if q is non-finite or out of limits.
  JointState MakeState(const Vector7d& q) const;

  /// Moves `state` one time step dt (s, > 0, else InputError) toward q_cmd (rad). A command
  /// with a non-finite entry is rejected and the robot brakes. No allocation.
  JointStepReport Step(const Vector7d& q_cmd, double dt, JointState* state) const;

  /// Brakes every joint to rest at its acceleration limit for one step dt (s).
  void Brake(double dt, JointState* state) const;

 private:
  // integrates qd over dt, stopping joints on their position limits
  void Integrate(double dt, JointState* state) const;

  const Iiwa14Model& model_;
};

}  // namespace nsim
