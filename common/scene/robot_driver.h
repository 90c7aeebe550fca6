#pragma once
// The robot that holds the needle in the direct simulation: a 6-DoF Cartesian end effector or a
// KUKA LBR iiwa 14 on its base pose, executing flange-pose (or joint) commands under its limits
// (common/robot), and the planned insertion path the robot starts from.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "common/needle/rigid_needle.h"
#include "common/robot/cartesian_robot.h"
#include "common/robot/iiwa14.h"
#include "common/robot/iiwa14_ik.h"
#include "common/robot/joint_interpolator.h"

namespace nsim {

enum class RobotKind { kCartesian, kIiwa };

/// Which robot and its limits.
struct RobotDriverConfig {
  RobotKind kind = RobotKind::kCartesian;
  CartesianRobotConfig cartesian;  ///< limits of the Cartesian robot
  Iiwa14Config iiwa;               ///< base pose X_WB and limits of the iiwa (X_FT unused)
  Iiwa14IkConfig ik;               ///< IK of Cartesian commands for the iiwa

  /// Throws InputError "robot.<key> ...".
  void Validate() const;
};

/// What one robot step did.
struct RobotStepReport {
  bool limited = false;    ///< a rate, workspace or joint limit was active
  bool ik_failed = false;  ///< iiwa: the Cartesian command had no exact IK solution (best used)
};

/// The robot's model and state together; the flange F is the end effector E.
class RobotDriver {
 public:
  /// A robot at rest with its flange at X_WE. InputError when X_WE is outside the workspace
  /// (Cartesian) or unreachable (iiwa).
  RobotDriver(const RobotDriverConfig& config, const Eigen::Isometry3d& X_WE);
  ~RobotDriver();

  /// One step of dt (s) toward the flange pose X_WE_cmd.
  RobotStepReport StepToPose(const Eigen::Isometry3d& X_WE_cmd, double dt);
  /// One step toward joint angles (rad; iiwa only, 7 entries; NSIM_CHECKed).
  RobotStepReport StepToJoints(const std::vector<double>& q_cmd, double dt);
  /// Brakes toward rest for one step (the safe action when there is no valid command).
  void Hold(double dt);

  /// Flange pose now.
  const Eigen::Isometry3d& X_WE() const { return X_WE_; }
  /// Joint angles now (rad), 7 entries for the iiwa, empty for the Cartesian robot.
  std::vector<double> q() const;
  /// iiwa: the smallest distance of a joint to its nearer position limit now (rad; negative
  /// beyond it). Cartesian robot: +infinity (it has no joints).
  double joint_limit_margin() const;
  /// Flange linear speed over the last step (m/s).
  double linear_speed() const { return speed_; }
  const RobotDriverConfig& config() const { return config_; }

 private:
  void UpdatePose(double dt);

  RobotDriverConfig config_;
  std::unique_ptr<CartesianRobot> cartesian_;
  CartesianRobotState cartesian_state_;
  std::unique_ptr<Iiwa14Model> iiwa_;
  std::unique_ptr<Iiwa14InverseKinematics> ik_;
  std::unique_ptr<JointInterpolator> joints_;
  JointState joint_state_;
  Eigen::Isometry3d X_WE_ = Eigen::Isometry3d::Identity();
  double speed_ = 0.0;
};

/// The planned straight insertion from a start point in front of the skin, through the entry
/// point, to the target; the needle is aligned with the path.
struct InsertionPlan {
  Eigen::Vector3d p_entry = Eigen::Vector3d::Zero();     ///< planned skin entry (m)
  Eigen::Vector3d p_target = Eigen::Vector3d::Zero();    ///< target at rest (m)
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< unit, entry -> target
  double approach_distance = 0.0;  ///< the tip starts this far before the entry (m)
  Eigen::Isometry3d R_WN_frame = Eigen::Isometry3d::Identity();  ///< needle orientation (rotation)
  Eigen::Isometry3d X_FN = Eigen::Isometry3d::Identity();        ///< tool offset of the needle
  double needle_length = 0.0;                                    ///< (m)

  /// Start tip position p_entry - approach_distance direction (m).
  Eigen::Vector3d start_tip() const { return p_entry - approach_distance * direction; }
  /// Travel of the tip from the start to the target (m).
  double total_travel() const { return approach_distance + (p_target - p_entry).norm(); }
  /// Flange pose that puts the tip at start_tip() + s direction, the needle along the path.
  Eigen::Isometry3d CalcFlangePose(double s) const;
};

/// Builds the plan (InputError when entry and target coincide or approach_distance < 0).
InsertionPlan MakeInsertionPlan(const Eigen::Vector3d& p_entry, const Eigen::Vector3d& p_target,
                                const RigidNeedleModel& needle, double approach_distance);

}  // namespace nsim
