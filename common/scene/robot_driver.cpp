#include "common/scene/robot_driver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {

void RobotDriverConfig::Validate() const {
  cartesian.Validate();
  if (kind == RobotKind::kIiwa) {
    iiwa.Validate();
    ik.Validate();
  }
}

RobotDriver::RobotDriver(const RobotDriverConfig& config, const Eigen::Isometry3d& X_WE)
    : config_(config) {
  config_.Validate();
  if (config_.kind == RobotKind::kCartesian) {
    cartesian_ = std::make_unique<CartesianRobot>(config_.cartesian);
    cartesian_state_ = cartesian_->MakeState(X_WE);
  } else {
    Iiwa14Config iiwa = config_.iiwa;
    iiwa.X_FT = Eigen::Isometry3d::Identity();  // commands are flange poses
    iiwa_ = std::make_unique<Iiwa14Model>(iiwa);
    ik_ = std::make_unique<Iiwa14InverseKinematics>(*iiwa_, config_.ik);
    joints_ = std::make_unique<JointInterpolator>(*iiwa_);
    const Iiwa14IkResult ik = ik_->Solve(X_WE, iiwa_->CalcMidRange());
    if (!ik.success)
      throw InputError(
          Str("robot: the start flange pose is out of the iiwa's reach from its "
              "base (IK position error ",
              ik.position_error, " m)"));
    joint_state_ = joints_->MakeState(ik.q);
  }
  UpdatePose(0.0);
}

RobotDriver::~RobotDriver() = default;

void RobotDriver::UpdatePose(double dt) {
  const Eigen::Vector3d p_before = X_WE_.translation();
  X_WE_ = cartesian_ ? cartesian_state_.X_WE : iiwa_->CalcToolPose(joint_state_.q);
  speed_ = dt > 0 ? (X_WE_.translation() - p_before).norm() / dt : 0.0;
}

RobotStepReport RobotDriver::StepToPose(const Eigen::Isometry3d& X_WE_cmd, double dt) {
  RobotStepReport report;
  if (cartesian_) {
    const CartesianStepReport r = cartesian_->Step(X_WE_cmd, dt, &cartesian_state_);
    report.limited = r.rate_limited || r.clamped_to_workspace || !r.accepted;
  } else {
    const Iiwa14IkResult ik = ik_->Solve(X_WE_cmd, joint_state_.q);
    report.ik_failed = !ik.success;
    const JointStepReport r = joints_->Step(ik.q, dt, &joint_state_);
    report.limited = r.rate_limited || r.clamped_to_limits;
  }
  UpdatePose(dt);
  return report;
}

RobotStepReport RobotDriver::StepToJoints(const std::vector<double>& q_cmd, double dt) {
  NSIM_CHECK(iiwa_ && q_cmd.size() == kIiwaNumJoints, "joint command for a Cartesian robot");
  RobotStepReport report;
  const JointStepReport r =
      joints_->Step(Eigen::Map<const Vector7d>(q_cmd.data()), dt, &joint_state_);
  report.limited = r.rate_limited || r.clamped_to_limits;
  UpdatePose(dt);
  return report;
}

void RobotDriver::Hold(double dt) {
  if (cartesian_) {
    cartesian_->Brake(dt, &cartesian_state_);
  } else {
    joints_->Brake(dt, &joint_state_);
  }
  UpdatePose(dt);
}

std::vector<double> RobotDriver::q() const {
  if (!iiwa_) return {};
  return std::vector<double>(joint_state_.q.data(), joint_state_.q.data() + kIiwaNumJoints);
}

double RobotDriver::joint_limit_margin() const {
  if (!iiwa_) return std::numeric_limits<double>::infinity();
  const Iiwa14Config& c = config_.iiwa;
  return std::min((joint_state_.q - c.position_lower).minCoeff(),
                  (c.position_upper - joint_state_.q).minCoeff());
}

Eigen::Isometry3d InsertionPlan::CalcFlangePose(double s) const {
  Eigen::Isometry3d X_WN = R_WN_frame;
  X_WN.translation() = start_tip() + s * direction - needle_length * direction;
  return X_WN * X_FN.inverse();
}

InsertionPlan MakeInsertionPlan(const Eigen::Vector3d& p_entry, const Eigen::Vector3d& p_target,
                                const RigidNeedleModel& needle, double approach_distance) {
  const Eigen::Vector3d path = p_target - p_entry;
  if (!(path.norm() > 1e-6) || !path.allFinite())
    throw InputError("insertion plan: entry and target must be distinct finite points");
  if (!(approach_distance >= 0))
    throw InputError(Str("robot.approach_distance must be >= 0 (m), got ", approach_distance));
  InsertionPlan plan;
  plan.p_entry = p_entry;
  plan.p_target = p_target;
  plan.direction = path.normalized();
  plan.approach_distance = approach_distance;
  plan.X_FN = needle.get_tool_offset();
  plan.needle_length = needle.length();
  // needle frame: z along the path, x the world x made orthogonal (world y if nearly parallel)
  const Eigen::Vector3d z = plan.direction;
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z.x() * z;
  if (x.norm() < 0.1) x = Eigen::Vector3d::UnitY() - z.y() * z;
  x.normalize();
  plan.R_WN_frame.linear().col(0) = x;
  plan.R_WN_frame.linear().col(1) = z.cross(x);
  plan.R_WN_frame.linear().col(2) = z;
  return plan;
}

}  // namespace nsim
