#include "common/robot/joint_interpolator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/robot/rate_limit.h"

namespace nsim {
namespace {

void CheckDt(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw InputError(Str("joint time step must be > 0 and finite (s), got ", dt));
  }
}

}  // namespace

JointState JointInterpolator::MakeState(const Vector7d& q) const {
  if (!q.allFinite() || !model_.IsWithinLimits(q)) {
    throw InputError(Str("iiwa initial joints must be finite and within the position limits, got (",
                         q.transpose(), ") rad"));
  }
  JointState state;
  state.q = q;
  return state;
}

void JointInterpolator::Integrate(double dt, JointState* state) const {
  const Iiwa14Config& c = model_.config();
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    const double q_new = state->q[i] + state->qd[i] * dt;
    if (q_new < c.position_lower[i] || q_new > c.position_upper[i]) {
      const double q_clamped = std::min(std::max(q_new, c.position_lower[i]), c.position_upper[i]);
      state->qd[i] = (q_clamped - state->q[i]) / dt;
      state->q[i] = q_clamped;
    } else {
      state->q[i] = q_new;
    }
  }
}

void JointInterpolator::Brake(double dt, JointState* state) const {
  CheckDt(dt);
  const Iiwa14Config& c = model_.config();
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    Eigen::Matrix<double, 1, 1> v(state->qd[i]);
    StepVelocityToRest<1>(c.acceleration_limit[i], dt, &v);
    state->qd[i] = v[0];
  }
  Integrate(dt, state);
}

JointStepReport JointInterpolator::Step(const Vector7d& q_cmd, double dt, JointState* state) const {
  CheckDt(dt);
  JointStepReport report;
  if (!q_cmd.allFinite()) {
    report.accepted = false;
    report.rate_limited = true;
    report.max_error = std::numeric_limits<double>::quiet_NaN();
    Brake(dt, state);
    return report;
  }
  const Vector7d target = model_.ClampToLimits(q_cmd);
  report.clamped_to_limits = target != q_cmd;
  const Iiwa14Config& c = model_.config();
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    Eigen::Matrix<double, 1, 1> error(target[i] - state->q[i]);
    Eigen::Matrix<double, 1, 1> v(state->qd[i]);
    StepVelocityTowards<1>(error, c.velocity_limit[i], c.acceleration_limit[i], dt, &v);
    state->qd[i] = v[0];
  }
  Integrate(dt, state);
  report.max_error = (target - state->q).cwiseAbs().maxCoeff();
  report.rate_limited = report.max_error > 1e-12;
  return report;
}

}  // namespace nsim
