#include "common/robot/motion_forecast.h"

#include <cmath>

#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {

namespace {

void CheckStep(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw InputError(Str("motion forecast: the step must be > 0 and finite (s), got ", dt));
}

}  // namespace

MotionForecast::MotionForecast(const MotionForecastConfig& config)
    : cartesian_(config.cartesian), iiwa_(config.iiwa), joints_(iiwa_) {}

void MotionForecast::Observe(double t, const Eigen::Isometry3d& X_WE,
                             const std::vector<double>& q) {
  if (!std::isfinite(t) || !IsRigidTransform(X_WE, 1e-6))
    throw InputError("motion forecast: a measured state needs a finite time and a rigid pose");
  const bool joints = !q.empty();
  if (joints && q.size() != static_cast<size_t>(kIiwaNumJoints))
    throw InputError(Str("motion forecast: expected 7 joint angles, got ", q.size()));
  Vector7d q7 = Vector7d::Zero();
  if (joints) {
    q7 = Eigen::Map<const Vector7d>(q.data());
    if (!q7.allFinite()) throw InputError("motion forecast: joint angles must be finite");
  }
  const double dt = t - t_;
  has_velocity_ = has_state_ && joints == has_joints_ && dt > 0.0;
  if (has_velocity_) {
    // the semi-implicit step makes the mean velocity over the step its end velocity
    pose_state_.v_WE = (X_WE.translation() - pose_state_.X_WE.translation()) / dt;
    pose_state_.w_WE = LogSO3(X_WE.linear() * pose_state_.X_WE.linear().transpose()) / dt;
    if (joints) {
      const Vector7d& limit = iiwa_.config().velocity_limit;
      joint_state_.qd = ((q7 - joint_state_.q) / dt).cwiseMax(-limit).cwiseMin(limit);
    }
  } else {
    pose_state_.v_WE.setZero();
    pose_state_.w_WE.setZero();
    joint_state_.qd.setZero();
  }
  pose_state_.X_WE = X_WE;
  joint_state_.q = q7;
  has_joints_ = joints;
  has_state_ = true;
  t_ = t;
}

Vector7d MotionForecast::ForecastJoints(const std::vector<Vector7d>& commands, double dt) const {
  CheckStep(dt);
  if (!has_state_ || !has_joints_)
    throw InputError("motion forecast: no measured joint angles to forecast from");
  JointState state = joint_state_;
  for (const Vector7d& q_cmd : commands) joints_.Step(q_cmd, dt, &state);
  return state.q;
}

Eigen::Isometry3d MotionForecast::ForecastPose(const std::vector<Eigen::Isometry3d>& commands,
                                               double dt) const {
  CheckStep(dt);
  if (!has_state_) throw InputError("motion forecast: no measured pose to forecast from");
  CartesianRobotState state = pose_state_;
  for (const Eigen::Isometry3d& X_cmd : commands) cartesian_.Step(X_cmd, dt, &state);
  return state.X_WE;
}

}  // namespace nsim
