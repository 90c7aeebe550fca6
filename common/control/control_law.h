#pragma once
// The control law of the inverse simulation: one regularized Newton step on the objectives,
//   Cartesian (thesis eq. 3.9): T(i+1) = chi(i) - J_6r^+ (k . e(i))
//   joints    (thesis eq. A.3): q(i+1) = q(i) - J_7r^+ (k . e(i))
// with J the finite-difference Jacobian (finite_difference_jacobian.h), J_r^+ its Tikhonov
// inverse (regularized_inverse.h) and k a gain per objective row (Hadamard product).
// The sign: J = de/dchi, so the step -J^+ e is the Newton step toward e = 0; with k in (0, 1]
// a linear system's error shrinks by (1 - k) per iteration.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/control/regularized_inverse.h"
#include "common/robot/iiwa14.h"
#include "common/robot/pose_math.h"

namespace nsim {

/// Settings of the control law. The step caps are a safety net on one iteration's motion
/// (the robot's interpolator limits speed and acceleration separately).
struct ControlLawConfig {
  double regularization = 1e-6;  ///< r of eq. 3.7-3.8, > 0, units of J^T J's eigenvalues
  TikhonovForm tikhonov_form = TikhonovForm::kClampedSpectrum;  ///< reading of eq. 3.7
  /// frame of the 6-vector step; must match the frame the Jacobian was perturbed in
  PoseIncrementFrame frame = PoseIncrementFrame::kWorldAligned;
  double max_translation_step = 0.01;  ///< cap on |dp| per iteration (m), > 0
  double max_rotation_step = 0.1;      ///< cap on |dtheta| per iteration (rad), > 0
  double max_joint_step = 0.1;         ///< cap on max_i |dq_i| per iteration (rad), > 0

  /// Throws InputError naming the first invalid field, e.g.
  /// "control.regularization must be > 0, got 0".
  void Validate() const;
};

/// Outcome of one Cartesian control step.
struct CartesianControlOutput {
  bool valid = true;          ///< false: non-finite J, e or step; the target is the current pose
  bool step_limited = false;  ///< the step was scaled down to the caps (direction kept)
  Eigen::Isometry3d X_WE_target = Eigen::Isometry3d::Identity();  ///< T(i+1)
  Vector6d delta = Vector6d::Zero();  ///< applied step [dp (m); dtheta (rad)] in config.frame
};

/// Outcome of one joint control step.
struct JointControlOutput {
  bool valid = true;          ///< false: non-finite J, e or step; the target is the current q
  bool step_limited = false;  ///< the step was scaled down to max_joint_step (direction kept)
  Vector7d q_target = Vector7d::Zero();  ///< q(i+1) (rad), not clamped to the joint limits
  Vector7d delta = Vector7d::Zero();     ///< applied step (rad)
};

/// delta = -J_r^+ (k . e): J_r_plus n x m, k and e m-vectors. Throws InputError on mismatched
/// sizes. delta is resized to n.
void CalcControlStep(const Eigen::MatrixXd& J_r_plus, const Eigen::VectorXd& k,
                     const Eigen::VectorXd& e, Eigen::VectorXd* delta);

/// Thesis eq. 3.9 for the Cartesian robot: J is m x 6 (columns [dp; dtheta] in config.frame),
/// e and k m-vectors. Throws InputError on mismatched sizes or a negative gain; a non-finite
/// J or e gives valid = false and holds X_WE.
CartesianControlOutput CalcCartesianTarget(const Eigen::Isometry3d& X_WE, const Eigen::MatrixXd& J,
                                           const Eigen::VectorXd& e, const Eigen::VectorXd& k,
                                           const ControlLawConfig& config);

/// Thesis eq. A.3 for the iiwa's joints: J is m x 7. Same errors and safe behaviour as
/// CalcCartesianTarget.
JointControlOutput CalcJointTarget(const Vector7d& q, const Eigen::MatrixXd& J,
                                   const Eigen::VectorXd& e, const Eigen::VectorXd& k,
                                   const ControlLawConfig& config);

}  // namespace nsim
