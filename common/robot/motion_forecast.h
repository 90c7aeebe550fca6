#pragma once
// Where the robot will be once the commands already sent to it have been executed: the robot's
// own motion law (CartesianRobot, JointInterpolator: the same speed and acceleration limits as
// the patient side's robot) run forward from its last measured state, one command per step.
//
// The controller sends a command every frame and, with d frames of latency, d of them are in
// flight. The Smith-predictor form of the law (README "Control under latency") assumes the
// robot reaches each command within a step; a robot limited in acceleration does not when the
// commands jump (0.5 m/s^2 reaches 1 mm in 4-5 steps; the iiwa's joints 0.01 rad in 3-4), so
// the last command is not where the needle will be. The forecast is.
//
// A SensorFrame carries the pose and the joints, not their rates: the velocity is the
// difference of the last two measured states over their time difference, which is exact for
// consecutive frames because both interpolators integrate semi-implicitly (x' = x + v' dt,
// common/robot/rate_limit.h).

#include <Eigen/Geometry>
#include <vector>

#include "common/robot/cartesian_robot.h"
#include "common/robot/iiwa14.h"
#include "common/robot/joint_interpolator.h"

namespace nsim {

/// The limits the forecast runs the robot under (the patient side's robot section).
struct MotionForecastConfig {
  CartesianRobotConfig cartesian;  ///< the Cartesian robot's speed and acceleration limits
  Iiwa14Config iiwa;               ///< the iiwa's joint position, speed and acceleration limits
};

class MotionForecast {
 public:
  /// Validates both configs (InputError naming the field).
  explicit MotionForecast(const MotionForecastConfig& config);

  /// A measured state at time t (s): the flange pose and, for the iiwa, its 7 joint angles
  /// (empty for the Cartesian robot). Its velocity is the change since the previous state over
  /// their time difference; a state that does not follow the previous one in time, or a change
  /// of robot kind, starts over at rest. InputError for a non-finite time or joint angle, a pose
  /// that is not rigid or a joint vector that is not 7 long (the state before is kept).
  void Observe(double t, const Eigen::Isometry3d& X_WE, const std::vector<double>& q);

  /// At least one state was observed.
  bool has_state() const { return has_state_; }
  /// The velocity is known (two states one after the other).
  bool has_velocity() const { return has_velocity_; }

  /// The joint angles after executing `commands` in order, each for one step of dt (s, > 0),
  /// from the last measured state (InputError before a state with joints was observed).
  Vector7d ForecastJoints(const std::vector<Vector7d>& commands, double dt) const;
  /// The flange pose after executing the Cartesian `commands` in order, each for one step of
  /// dt (s, > 0), from the last measured state (InputError before any state).
  Eigen::Isometry3d ForecastPose(const std::vector<Eigen::Isometry3d>& commands, double dt) const;

 private:
  CartesianRobot cartesian_;
  Iiwa14Model iiwa_;
  JointInterpolator joints_;
  bool has_state_ = false;
  bool has_velocity_ = false;
  bool has_joints_ = false;
  double t_ = 0.0;
  CartesianRobotState pose_state_;
  JointState joint_state_;
};

}  // namespace nsim
