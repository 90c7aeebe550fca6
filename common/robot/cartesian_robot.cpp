#include "common/robot/cartesian_robot.h"

#include <cmath>
#include <limits>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/robot/rate_limit.h"

namespace nsim {
namespace {

void CheckPositive(double value, const char* name, const char* unit, double max) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw InputError(Str("robot.", name, " must be > 0 (", unit, "), got ", value));
  }
  CheckAtMost(value, max, Str("robot.", name), unit);
}

void CheckDt(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw InputError(Str("robot time step must be > 0 and finite (s), got ", dt));
  }
}

}  // namespace

void CartesianRobotConfig::Validate() const {
  // Upper bounds no robot arm reaches: an industrial arm's tool moves at most ~2 m/s (the
  // iiwa 14 far less, a needle robot in tissue at mm/s), turns at ~10 rad/s (the iiwa's
  // fastest joint is 3.1 rad/s) and accelerates at ~5 g (50 m/s^2), 500 rad/s^2 in rotation.
  CheckPositive(max_linear_speed, "max_linear_speed", "m/s", 2.0);
  CheckPositive(max_angular_speed, "max_angular_speed", "rad/s", 10.0);
  CheckPositive(max_linear_acceleration, "max_linear_acceleration", "m/s^2", 50.0);
  CheckPositive(max_angular_acceleration, "max_angular_acceleration", "rad/s^2", 500.0);
  static const char* kAxis[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(workspace_min_W[i]) || !std::isfinite(workspace_max_W[i]) ||
        !(workspace_min_W[i] < workspace_max_W[i])) {
      throw InputError(Str("robot.workspace_min_W.", kAxis[i], " must be < robot.workspace_max_W.",
                           kAxis[i], " (m), got ", workspace_min_W[i], " and ",
                           workspace_max_W[i]));
    }
    // an arm reaches about 1 m; 10 m from the scene's origin is no workspace
    CheckRange(workspace_min_W[i], -10.0, 10.0, Str("robot.workspace_min_W.", kAxis[i]), "m");
    CheckRange(workspace_max_W[i], -10.0, 10.0, Str("robot.workspace_max_W.", kAxis[i]), "m");
  }
}

CartesianRobot::CartesianRobot(const CartesianRobotConfig& config) : config_(config) {
  config_.Validate();
}

CartesianRobotState CartesianRobot::MakeState(const Eigen::Isometry3d& X_WE) const {
  if (!IsRigidTransform(X_WE, 1e-6)) {
    throw InputError("robot initial pose X_WE must be a finite rigid transform");
  }
  if (!IsInWorkspace(X_WE.translation())) {
    throw InputError(Str("robot initial position p_WE must lie in the workspace box, got (",
                         X_WE.translation().transpose(), ") m"));
  }
  CartesianRobotState state;
  state.X_WE = X_WE;
  return state;
}

Eigen::Vector3d CartesianRobot::ClampToWorkspace(const Eigen::Vector3d& p_W) const {
  return p_W.cwiseMax(config_.workspace_min_W).cwiseMin(config_.workspace_max_W);
}

bool CartesianRobot::IsInWorkspace(const Eigen::Vector3d& p_W) const {
  return (p_W.array() >= config_.workspace_min_W.array()).all() &&
         (p_W.array() <= config_.workspace_max_W.array()).all();
}

void CartesianRobot::Integrate(double dt, CartesianRobotState* state) const {
  const Eigen::Vector3d p_old = state->X_WE.translation();
  const Eigen::Vector3d p_new = ClampToWorkspace(p_old + state->v_WE * dt);
  if (p_new != p_old + state->v_WE * dt) state->v_WE = (p_new - p_old) / dt;
  state->X_WE.translation() = p_new;
  // rotate on the geodesic, then renormalize through a unit quaternion to stop drift
  const Eigen::Matrix3d R = ExpSO3(state->w_WE * dt) * state->X_WE.linear();
  state->X_WE.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
}

void CartesianRobot::Brake(double dt, CartesianRobotState* state) const {
  CheckDt(dt);
  StepVelocityToRest<3>(config_.max_linear_acceleration, dt, &state->v_WE);
  StepVelocityToRest<3>(config_.max_angular_acceleration, dt, &state->w_WE);
  Integrate(dt, state);
}

CartesianStepReport CartesianRobot::Step(const Eigen::Isometry3d& X_WE_cmd, double dt,
                                         CartesianRobotState* state) const {
  CheckDt(dt);
  CartesianStepReport report;
  if (!IsRigidTransform(X_WE_cmd, 1e-6)) {
    report.accepted = false;
    report.rate_limited = true;
    report.position_error = std::numeric_limits<double>::quiet_NaN();
    report.orientation_error = std::numeric_limits<double>::quiet_NaN();
    Brake(dt, state);
    return report;
  }
  const Eigen::Vector3d p_cmd = ClampToWorkspace(X_WE_cmd.translation());
  report.clamped_to_workspace = p_cmd != X_WE_cmd.translation();
  const Eigen::Matrix3d R_cmd = X_WE_cmd.linear();

  // linear: straight line toward the clamped target
  const Eigen::Vector3d e_p = p_cmd - state->X_WE.translation();
  StepVelocityTowards<3>(e_p, config_.max_linear_speed, config_.max_linear_acceleration, dt,
                         &state->v_WE);
  // angular: the rotation vector of R_cmd R^T, in world-aligned axes
  const Eigen::Vector3d e_r = LogSO3(R_cmd * state->X_WE.linear().transpose());
  StepVelocityTowards<3>(e_r, config_.max_angular_speed, config_.max_angular_acceleration, dt,
                         &state->w_WE);
  Integrate(dt, state);

  report.position_error = (p_cmd - state->X_WE.translation()).norm();
  report.orientation_error = CalcRotationAngle(R_cmd, state->X_WE.linear());
  // "reached" up to rounding of the last step
  report.rate_limited = report.position_error > 1e-12 || report.orientation_error > 1e-12;
  return report;
}

}  // namespace nsim
