#pragma once
// The Cartesian 6-DoF robot holding the needle (thesis §3.3, Adagolodjo's and Baksic's robot
// model): its end effector E follows commanded poses X_WE under speed and acceleration limits,
// inside a world-aligned workspace box.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/robot/pose_math.h"

namespace nsim {

/// Limits of the Cartesian robot. SI units; boxes in the world frame W.
struct CartesianRobotConfig {
  double max_linear_speed = 0.05;                     ///< |v_WE| limit (m/s), > 0
  double max_angular_speed = 0.5;                     ///< |w_WE| limit (rad/s), > 0
  double max_linear_acceleration = 0.5;               ///< |dv_WE/dt| limit (m/s^2), > 0
  double max_angular_acceleration = 5.0;              ///< |dw_WE/dt| limit (rad/s^2), > 0
  Eigen::Vector3d workspace_min_W{-1.0, -1.0, -1.0};  ///< lower corner of the box for p_WE (m)
  Eigen::Vector3d workspace_max_W{1.0, 1.0, 1.0};     ///< upper corner (m), > min on every axis

  /// Throws InputError naming the first invalid field, e.g.
  /// "robot.max_linear_speed must be > 0 (m/s), got -1".
  void Validate() const;
};

/// Mutable state of the Cartesian robot. Cheap to copy.
struct CartesianRobotState {
  Eigen::Isometry3d X_WE = Eigen::Isometry3d::Identity();  ///< end-effector pose in world
  Eigen::Vector3d v_WE = Eigen::Vector3d::Zero();          ///< velocity of E's origin in W (m/s)
  Eigen::Vector3d w_WE = Eigen::Vector3d::Zero();          ///< angular velocity of E in W (rad/s)
};

/// What happened to one command.
struct CartesianStepReport {
  bool accepted = true;               ///< false: non-finite or non-rigid command, robot braked
  bool clamped_to_workspace = false;  ///< the commanded position was outside the box
  bool rate_limited = false;          ///< the robot did not reach the (clamped) command this step
  double position_error = 0.0;        ///< |p_cmd - p_WE| after the step (m), clamped command
  double orientation_error = 0.0;     ///< angle between R_cmd and R_WE after the step (rad)
};

/// Model of the Cartesian robot: immutable limits; Step() advances a CartesianRobotState.
/// Translation and rotation are limited independently: p moves on a straight line toward the
/// (clamped) target, R on the SO(3) geodesic R' = Exp(w dt) R with w along Log(R_cmd R^T), each
/// with the discrete braking law of StepVelocityTowards(), so from rest toward a fixed target
/// neither overshoots. The box is a hard limit: if a moving target makes the straight-line
/// motion leave it, the position is clamped (and the velocity set to the clamped displacement
/// over dt), which is the one case where the acceleration limit yields to the workspace.
class CartesianRobot {
 public:
  /// Validates `config` (throws InputError).
  explicit CartesianRobot(const CartesianRobotConfig& config);

  const CartesianRobotConfig& config() const { return config_; }

  /// A state at rest at X_WE. Throws InputError if X_WE is not a finite rigid transform or its
  /// position lies outside the workspace box.
  CartesianRobotState MakeState(const Eigen::Isometry3d& X_WE) const;

  /// Moves `state` one time step dt (s, > 0 and finite, else InputError) toward the commanded
  /// pose X_WE_cmd. A command that is not a finite rigid transform (tolerance 1e-6) is
  /// rejected: the robot brakes at its acceleration limits and the report says accepted=false.
  /// No allocation.
  CartesianStepReport Step(const Eigen::Isometry3d& X_WE_cmd, double dt,
                           CartesianRobotState* state) const;

  /// Brakes to rest at the acceleration limits for one step dt (s) (the safe action).
  void Brake(double dt, CartesianRobotState* state) const;

  /// The point of the workspace box nearest to p_W (m).
  Eigen::Vector3d ClampToWorkspace(const Eigen::Vector3d& p_W) const;

  /// True if p_W lies in the box (boundary included).
  bool IsInWorkspace(const Eigen::Vector3d& p_W) const;

 private:
  // integrates the velocities of `state` over dt, keeping p_WE in the box
  void Integrate(double dt, CartesianRobotState* state) const;

  CartesianRobotConfig config_;
};

}  // namespace nsim
