#include "common/control/control_law.h"

#include <algorithm>
#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {
namespace {

void CheckPositive(double value, const char* name, const char* unit) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw InputError(Str("control.", name, " must be > 0", unit, ", got ", value));
  }
}

void CheckShapes(const Eigen::MatrixXd& J, int dof, const Eigen::VectorXd& e,
                 const Eigen::VectorXd& k) {
  if (J.cols() != dof || J.rows() != e.size() || k.size() != e.size()) {
    throw InputError(Str("control law: expected J of m x ", dof, " and e, k of m rows, got J ",
                         J.rows(), " x ", J.cols(), ", e ", e.size(), ", k ", k.size()));
  }
  for (int i = 0; i < k.size(); ++i) {
    if (!(k[i] >= 0.0) || !std::isfinite(k[i])) {
      throw InputError(Str("control law: gain k[", i, "] must be >= 0 and finite, got ", k[i]));
    }
  }
}

// The law's step -J_r^+ k e with the configured Tikhonov pseudo-inverse of J
Eigen::VectorXd CalcRegularizedStep(const Eigen::MatrixXd& J, const Eigen::VectorXd& e,
                                    const Eigen::VectorXd& k, const ControlLawConfig& config) {
  Eigen::MatrixXd J_r_plus;
  CalcTikhonovPseudoInverse(J, config.regularization, &J_r_plus, config.tikhonov_form);
  Eigen::VectorXd step;
  CalcControlStep(J_r_plus, k, e, &step);
  return step;
}

}  // namespace

void ControlLawConfig::Validate() const {
  CheckPositive(regularization, "regularization", "");
  CheckPositive(max_translation_step, "max_translation_step", " (m)");
  CheckPositive(max_rotation_step, "max_rotation_step", " (rad)");
  CheckPositive(max_joint_step, "max_joint_step", " (rad)");
  // per control step (20 ms): 10 cm is 5 m/s, 1 rad is 50 rad/s, beyond any robot; a
  // regularization of 1e6 m^2 leaves no control at all
  CheckAtMost(max_translation_step, 0.1, "control.max_translation_step", "m");
  CheckAtMost(max_rotation_step, 1.0, "control.max_rotation_step", "rad");
  CheckAtMost(max_joint_step, 1.0, "control.max_joint_step", "rad");
  CheckAtMost(regularization, 1e6, "control.regularization", "");
}

void CalcControlStep(const Eigen::MatrixXd& J_r_plus, const Eigen::VectorXd& k,
                     const Eigen::VectorXd& e, Eigen::VectorXd* delta) {
  if (J_r_plus.cols() != e.size() || k.size() != e.size()) {
    throw InputError(Str("control step: expected J_r^+ of n x m and e, k of m rows, got J_r^+ ",
                         J_r_plus.rows(), " x ", J_r_plus.cols(), ", e ", e.size(), ", k ",
                         k.size()));
  }
  delta->resize(J_r_plus.rows());
  delta->noalias() = -J_r_plus * k.cwiseProduct(e);
}

CartesianControlOutput CalcCartesianTarget(const Eigen::Isometry3d& X_WE, const Eigen::MatrixXd& J,
                                           const Eigen::VectorXd& e, const Eigen::VectorXd& k,
                                           const ControlLawConfig& config) {
  CheckShapes(J, 6, e, k);
  CartesianControlOutput out;
  out.X_WE_target = X_WE;
  if (!J.allFinite() || !e.allFinite() || !IsFinitePose(X_WE)) {
    out.valid = false;
    return out;
  }
  Vector6d delta = CalcRegularizedStep(J, e, k, config);
  // one common scale keeps the direction of the Newton step
  const double dp = delta.segment<3>(kLinear).norm();
  const double dtheta = delta.segment<3>(kAngular).norm();
  if (!std::isfinite(dp) || !std::isfinite(dtheta)) {
    out.valid = false;
    return out;
  }
  const double scale =
      std::min({1.0, config.max_translation_step / dp, config.max_rotation_step / dtheta});
  if (scale < 1.0) {
    delta *= scale;
    out.step_limited = true;
  }
  out.delta = delta;
  out.X_WE_target = ApplyPoseIncrement(X_WE, delta, config.frame);
  return out;
}

JointControlOutput CalcJointTarget(const Vector7d& q, const Eigen::MatrixXd& J,
                                   const Eigen::VectorXd& e, const Eigen::VectorXd& k,
                                   const ControlLawConfig& config) {
  CheckShapes(J, kIiwaNumJoints, e, k);
  JointControlOutput out;
  out.q_target = q;
  if (!J.allFinite() || !e.allFinite() || !q.allFinite()) {
    out.valid = false;
    return out;
  }
  Vector7d delta = CalcRegularizedStep(J, e, k, config);
  if (!delta.allFinite()) {
    out.valid = false;
    return out;
  }
  const double largest = delta.cwiseAbs().maxCoeff();
  if (largest > config.max_joint_step) {
    delta *= config.max_joint_step / largest;
    out.step_limited = true;
  }
  out.delta = delta;
  out.q_target = q + delta;
  return out;
}

}  // namespace nsim
