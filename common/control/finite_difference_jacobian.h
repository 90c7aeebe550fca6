#pragma once
// The simulation Jacobian by central finite differences (thesis eq. 3.6 / A.1 for the 6
// operational DoF, eq. A.2 for the 7 joints):
//   J^j = (E(chi + dchi^j) - E(chi - dchi^j)) / (2 |dchi^j|),   dchi^j = h_j u_j,
// one positive and one negative perturbation per DoF: 12 evaluations for a pose, 14 for the
// iiwa's joints. The objectives are evaluated by a caller-supplied function of the perturbation
// (for the inverse simulation: one constraint solve with the needle at the perturbed pose). The
// evaluation must be free of side effects: every call starts from the same unperturbed state.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include "common/core/error.h"
#include "common/robot/iiwa14.h"
#include "common/robot/pose_math.h"

namespace nsim {

/// Outcome of one Jacobian estimate.
struct FiniteDifferenceStatus {
  int evaluations = 0;     ///< objective evaluations made: 2 n
  bool all_finite = true;  ///< false if any evaluation returned a non-finite entry (J is then
                           ///< not to be used: hold the robot)
};

/// The objectives as an interface, for evaluators that are objects rather than lambdas.
/// Evaluate() must not change the evaluator's observable state (hence const).
class ObjectiveEvaluator {
 public:
  virtual ~ObjectiveEvaluator() = default;
  /// The objective vector e (m rows) at the perturbation `delta` (n DoF) of the current
  /// configuration; delta = 0 is the unperturbed configuration.
  virtual Eigen::VectorXd Evaluate(const Eigen::VectorXd& delta) const = 0;
};

/// Throws InputError unless every step is finite and > 0; `what` names the steps in the text.
void CheckFiniteDifferenceSteps(const Eigen::VectorXd& steps, const char* what);

/// Assembles J (m x n) from 2 n evaluated samples ordered [e(+h_0 u_0), e(-h_0 u_0),
/// e(+h_1 u_1), ...] (the order of MakePosePerturbations / MakeJointPerturbations), for callers
/// that evaluate the perturbations themselves (e.g. in parallel). Throws InputError if the
/// count is not 2 n or the samples differ in size.
FiniteDifferenceStatus AssembleCentralDifferenceJacobian(
    const std::vector<Eigen::VectorXd>& samples, const Eigen::VectorXd& steps, Eigen::MatrixXd* J);

/// Central-difference Jacobian J (m x n) of `objectives` (any callable
/// Eigen::VectorXd(const Eigen::VectorXd& delta)) at delta = 0 with per-DoF steps h_j > 0
/// (units of DoF j). Eq. 3.6 / A.2. Throws InputError on bad steps or if evaluations differ in
/// size. Error O(h^2); exact for affine objectives up to rounding.
template <
    typename Objectives,
    typename = std::enable_if_t<!std::is_base_of_v<ObjectiveEvaluator, std::decay_t<Objectives>>>>
FiniteDifferenceStatus CalcCentralDifferenceJacobian(Objectives&& objectives,
                                                     const Eigen::VectorXd& steps,
                                                     Eigen::MatrixXd* J) {
  CheckFiniteDifferenceSteps(steps, "finite-difference steps");
  const int n = static_cast<int>(steps.size());
  FiniteDifferenceStatus status;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    delta[j] = steps[j];
    const Eigen::VectorXd e_plus = objectives(static_cast<const Eigen::VectorXd&>(delta));
    delta[j] = -steps[j];
    const Eigen::VectorXd e_minus = objectives(static_cast<const Eigen::VectorXd&>(delta));
    delta[j] = 0.0;
    status.evaluations += 2;
    if (j == 0) J->resize(e_plus.size(), n);
    if (e_plus.size() != J->rows() || e_minus.size() != J->rows()) {
      throw InputError(Str("objective evaluations must all have ", J->rows(), " rows, got ",
                           e_plus.size(), " and ", e_minus.size(), " at DoF ", j));
    }
    if (!e_plus.allFinite() || !e_minus.allFinite()) status.all_finite = false;
    J->col(j) = (e_plus - e_minus) / (2.0 * steps[j]);
  }
  return status;
}

/// The same for an ObjectiveEvaluator.
FiniteDifferenceStatus CalcCentralDifferenceJacobian(const ObjectiveEvaluator& evaluator,
                                                     const Eigen::VectorXd& steps,
                                                     Eigen::MatrixXd* J);

/// The 12 perturbed end-effector poses of eq. 3.6 / A.1, ordered +0, -0, +1, -1, ..., +5, -5:
/// ApplyPoseIncrement(X_WE, +-steps[j] u_j, frame), u_j the j-th unit 6-vector [dp; dtheta]
/// (DoF 0-2 translations (m), 3-5 rotations (rad) about the axes of `frame` through E's
/// origin). Throws InputError on bad steps or a non-rigid X_WE.
std::array<Eigen::Isometry3d, 12> MakePosePerturbations(const Eigen::Isometry3d& X_WE,
                                                        const Vector6d& steps,
                                                        PoseIncrementFrame frame);

/// The 14 perturbed joint vectors of eq. A.2, ordered +0, -0, ..., +6, -6: q +- steps[j] u_j
/// (rad). Not clamped to the joint limits: a perturbation is virtual.
std::array<Vector7d, 14> MakeJointPerturbations(const Vector7d& q, const Vector7d& steps);

/// J6 (m x 6) of pose objectives: `pose_objectives` is any callable
/// Eigen::VectorXd(const Eigen::Isometry3d& X_WE_perturbed), evaluated at the 12 poses of
/// MakePosePerturbations. Column j is de/d(dchi_j) in `frame` (eq. 3.6), consistent with
/// ApplyPoseIncrement, so the control law can apply -J^+ k e in the same frame.
template <typename PoseObjectives>
FiniteDifferenceStatus CalcPoseJacobian(const Eigen::Isometry3d& X_WE, const Vector6d& steps,
                                        PoseIncrementFrame frame, PoseObjectives&& pose_objectives,
                                        Eigen::MatrixXd* J) {
  if (!IsRigidTransform(X_WE, 1e-6)) {
    throw InputError("pose Jacobian: X_WE must be a finite rigid transform");
  }
  auto objectives = [&](const Eigen::VectorXd& delta) {
    return pose_objectives(ApplyPoseIncrement(X_WE, Vector6d(delta), frame));
  };
  return CalcCentralDifferenceJacobian(objectives, Eigen::VectorXd(steps), J);
}

/// J7 (m x 7) of joint objectives: `joint_objectives` is any callable
/// Eigen::VectorXd(const Vector7d& q_perturbed), evaluated at the 14 vectors of
/// MakeJointPerturbations (eq. A.2).
template <typename JointObjectives>
FiniteDifferenceStatus CalcJointJacobian(const Vector7d& q, const Vector7d& steps,
                                         JointObjectives&& joint_objectives, Eigen::MatrixXd* J) {
  auto objectives = [&](const Eigen::VectorXd& delta) {
    return joint_objectives(Vector7d(q + delta));
  };
  return CalcCentralDifferenceJacobian(objectives, Eigen::VectorXd(steps), J);
}

}  // namespace nsim
