#include "common/control/finite_difference_jacobian.h"

namespace nsim {

void CheckFiniteDifferenceSteps(const Eigen::VectorXd& steps, const char* what) {
  if (steps.size() < 1) throw InputError(Str(what, ": expected at least one DoF, got none"));
  for (int j = 0; j < steps.size(); ++j) {
    if (!(steps[j] > 0.0) || !std::isfinite(steps[j])) {
      throw InputError(Str(what, "[", j, "] must be > 0 and finite, got ", steps[j]));
    }
  }
}

FiniteDifferenceStatus AssembleCentralDifferenceJacobian(
    const std::vector<Eigen::VectorXd>& samples, const Eigen::VectorXd& steps, Eigen::MatrixXd* J) {
  CheckFiniteDifferenceSteps(steps, "finite-difference steps");
  const int n = static_cast<int>(steps.size());
  if (static_cast<int>(samples.size()) != 2 * n) {
    throw InputError(
        Str("expected ", 2 * n, " objective samples for ", n, " DoF, got ", samples.size()));
  }
  const Eigen::Index m = samples[0].size();
  FiniteDifferenceStatus status;
  status.evaluations = 2 * n;
  J->resize(m, n);
  for (int j = 0; j < n; ++j) {
    const Eigen::VectorXd& e_plus = samples[2 * j];
    const Eigen::VectorXd& e_minus = samples[2 * j + 1];
    if (e_plus.size() != m || e_minus.size() != m) {
      throw InputError(Str("objective samples must all have ", m, " rows, got ", e_plus.size(),
                           " and ", e_minus.size(), " at DoF ", j));
    }
    if (!e_plus.allFinite() || !e_minus.allFinite()) status.all_finite = false;
    J->col(j) = (e_plus - e_minus) / (2.0 * steps[j]);
  }
  return status;
}

FiniteDifferenceStatus CalcCentralDifferenceJacobian(const ObjectiveEvaluator& evaluator,
                                                     const Eigen::VectorXd& steps,
                                                     Eigen::MatrixXd* J) {
  return CalcCentralDifferenceJacobian(
      [&evaluator](const Eigen::VectorXd& delta) { return evaluator.Evaluate(delta); }, steps, J);
}

std::array<Eigen::Isometry3d, 12> MakePosePerturbations(const Eigen::Isometry3d& X_WE,
                                                        const Vector6d& steps,
                                                        PoseIncrementFrame frame) {
  CheckFiniteDifferenceSteps(Eigen::VectorXd(steps), "pose perturbation steps");
  if (!IsRigidTransform(X_WE, 1e-6)) {
    throw InputError("pose perturbations: X_WE must be a finite rigid transform");
  }
  std::array<Eigen::Isometry3d, 12> poses;
  for (int j = 0; j < 6; ++j) {
    Vector6d delta = Vector6d::Zero();
    delta[j] = steps[j];
    poses[2 * j] = ApplyPoseIncrement(X_WE, delta, frame);
    poses[2 * j + 1] = ApplyPoseIncrement(X_WE, -delta, frame);
  }
  return poses;
}

std::array<Vector7d, 14> MakeJointPerturbations(const Vector7d& q, const Vector7d& steps) {
  CheckFiniteDifferenceSteps(Eigen::VectorXd(steps), "joint perturbation steps");
  std::array<Vector7d, 14> out;
  for (int j = 0; j < kIiwaNumJoints; ++j) {
    out[2 * j] = q;
    out[2 * j][j] += steps[j];
    out[2 * j + 1] = q;
    out[2 * j + 1][j] -= steps[j];
  }
  return out;
}

}  // namespace nsim
