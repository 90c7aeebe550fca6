#include "common/robot/pose_math.h"

#include <cmath>

namespace nsim {

Eigen::Matrix3d Skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return S;
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  if (theta < 1e-8) {
    // second-order series; the third-order term is below 1e-24
    const Eigen::Matrix3d S = Skew(w);
    return Eigen::Matrix3d::Identity() + S + 0.5 * S * S;
  }
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  // vee(R - R^T) = 2 sin(t) u, trace(R) = 1 + 2 cos(t)
  const Eigen::Vector3d vee(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  const double sin_2 = vee.norm();  // 2 sin t
  const double cos_t = 0.5 * (R.trace() - 1.0);
  const double theta = std::atan2(0.5 * sin_2, cos_t);
  if (cos_t >= 0.0) {
    // t in [0, pi/2]: the antisymmetric part is well conditioned; t / sin t by series near 0
    const double ratio = theta < 1e-6 ? 1.0 + theta * theta / 6.0 : theta / std::sin(theta);
    return 0.5 * ratio * vee;
  }
  // t in (pi/2, pi]: (R + R^T) / 2 - cos t I = (1 - cos t) u u^T, with 1 - cos t >= 1
  const Eigen::Matrix3d uu =
      (0.5 * (R + R.transpose()) - cos_t * Eigen::Matrix3d::Identity()) / (1.0 - cos_t);
  int k = 0;
  uu.diagonal().maxCoeff(&k);
  Eigen::Vector3d u = uu.col(k) / std::sqrt(uu(k, k));
  if (u.dot(vee) < 0.0) u = -u;
  return theta * u;
}

Eigen::Matrix3d CalcSO3RightJacobianInverse(const Eigen::Vector3d& phi) {
  const double t = phi.norm();
  const Eigen::Matrix3d S = Skew(phi);
  double c = 0.0;
  if (t < 1e-4) {
    // 1/12 + t^2/720 + O(t^4)
    c = 1.0 / 12.0 + t * t / 720.0;
  } else {
    c = 1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
  }
  return Eigen::Matrix3d::Identity() + 0.5 * S + c * S * S;
}

Eigen::Isometry3d ApplyPoseIncrement(const Eigen::Isometry3d& X_WE, const Vector6d& delta,
                                     PoseIncrementFrame frame) {
  const Eigen::Vector3d dp = delta.segment<3>(kLinear);
  const Eigen::Matrix3d dR = ExpSO3(delta.segment<3>(kAngular));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  if (frame == PoseIncrementFrame::kWorldAligned) {
    X.linear() = dR * X_WE.linear();
    X.translation() = X_WE.translation() + dp;
  } else {
    X.linear() = X_WE.linear() * dR;
    X.translation() = X_WE.translation() + X_WE.linear() * dp;
  }
  return X;
}

Vector6d CalcPoseDifference(const Eigen::Isometry3d& X_WA, const Eigen::Isometry3d& X_WB,
                            PoseIncrementFrame frame) {
  Vector6d d;
  const Eigen::Vector3d p_BA_W = X_WA.translation() - X_WB.translation();
  if (frame == PoseIncrementFrame::kWorldAligned) {
    d.segment<3>(kLinear) = p_BA_W;
    d.segment<3>(kAngular) = LogSO3(X_WA.linear() * X_WB.linear().transpose());
  } else {
    d.segment<3>(kLinear) = X_WB.linear().transpose() * p_BA_W;
    d.segment<3>(kAngular) = LogSO3(X_WB.linear().transpose() * X_WA.linear());
  }
  return d;
}

double CalcRotationAngle(const Eigen::Matrix3d& R_A, const Eigen::Matrix3d& R_B) {
  return LogSO3(R_A.transpose() * R_B).norm();
}

bool IsFinitePose(const Eigen::Isometry3d& X) { return X.matrix().allFinite(); }

bool IsRigidTransform(const Eigen::Isometry3d& X, double tolerance) {
  if (!IsFinitePose(X)) return false;
  const Eigen::Matrix3d R = X.linear();
  const double orthogonality =
      (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return orthogonality <= tolerance && R.determinant() > 0.0;
}

}  // namespace nsim
