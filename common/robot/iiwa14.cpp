#include "common/robot/iiwa14.h"

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

void CheckVector(const Vector7d& v, const char* name, const char* unit) {
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    if (!(v[i] > 0.0) || !std::isfinite(v[i])) {
      throw InputError(Str("iiwa.", name, "[", i, "] must be > 0 (", unit, "), got ", v[i]));
    }
  }
}

}  // namespace

void Iiwa14Config::Validate() const {
  if (!IsRigidTransform(X_WB, 1e-9)) {
    throw InputError("iiwa.X_WB must be a finite rigid transform (orthonormal rotation)");
  }
  if (!IsRigidTransform(X_FT, 1e-9)) {
    throw InputError("iiwa.X_FT must be a finite rigid transform (orthonormal rotation)");
  }
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    if (!std::isfinite(position_lower[i]) || !std::isfinite(position_upper[i]) ||
        !(position_lower[i] < position_upper[i])) {
      throw InputError(Str("iiwa.position_lower[", i, "] must be < iiwa.position_upper[", i,
                           "] (rad), got ", position_lower[i], " and ", position_upper[i]));
    }
  }
  CheckVector(velocity_limit, "velocity_limit", "rad/s");
  CheckVector(acceleration_limit, "acceleration_limit", "rad/s^2");
}

const std::array<Eigen::Vector3d, kIiwaNumJoints>& Iiwa14Model::JointOrigins() {
  static const std::array<Eigen::Vector3d, kIiwaNumJoints> kOrigins = {
      Eigen::Vector3d(0, 0, 0),    Eigen::Vector3d(0, 0, 0.36), Eigen::Vector3d(0, 0, 0),
      Eigen::Vector3d(0, 0, 0.42), Eigen::Vector3d(0, 0, 0),    Eigen::Vector3d(0, 0, 0.40),
      Eigen::Vector3d(0, 0, 0)};
  return kOrigins;
}

const std::array<Eigen::Vector3d, kIiwaNumJoints>& Iiwa14Model::JointAxes() {
  static const std::array<Eigen::Vector3d, kIiwaNumJoints> kAxes = {
      Eigen::Vector3d::UnitZ(),  Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
      -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY(),
      Eigen::Vector3d::UnitZ()};
  return kAxes;
}

Iiwa14Model::Iiwa14Model(const Iiwa14Config& config) : config_(config) { config_.Validate(); }

void Iiwa14Model::CalcForwardKinematics(const Vector7d& q, Iiwa14Kinematics* kin) const {
  const auto& origins = JointOrigins();
  const auto& axes = JointAxes();
  kin->q = q;
  // walk the chain in world: X_W(i) = X_W(i-1) * Trans(origin_i) * Rot(axis_i, q_i)
  Eigen::Matrix3d R = config_.X_WB.linear();
  Eigen::Vector3d p = config_.X_WB.translation();
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    p += R * origins[i];
    kin->p_WJ[i] = p;
    kin->a_W[i] = R * axes[i];
    R = R * Eigen::AngleAxisd(q[i], axes[i]).toRotationMatrix();
    kin->X_WL[i].linear() = R;
    kin->X_WL[i].translation() = p;
    kin->X_WL[i].makeAffine();
  }
  kin->X_WF.linear() = R;
  kin->X_WF.translation() = p + R * FlangeOffset();
  kin->X_WF.makeAffine();
  kin->X_WT = kin->X_WF * config_.X_FT;
}

Eigen::Isometry3d Iiwa14Model::CalcFlangePoseInBase(const Vector7d& q) const {
  const auto& origins = JointOrigins();
  const auto& axes = JointAxes();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    p += R * origins[i];
    R = R * Eigen::AngleAxisd(q[i], axes[i]).toRotationMatrix();
  }
  Eigen::Isometry3d X_BF = Eigen::Isometry3d::Identity();
  X_BF.linear() = R;
  X_BF.translation() = p + R * FlangeOffset();
  return X_BF;
}

Eigen::Isometry3d Iiwa14Model::CalcToolPose(const Vector7d& q) const {
  return config_.X_WB * CalcFlangePoseInBase(q) * config_.X_FT;
}

void Iiwa14Model::CalcJacobian(const Iiwa14Kinematics& kin, const Eigen::Vector3d& p_WP,
                               Jacobian67* J) const {
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    J->block<3, 1>(kLinear, i) = kin.a_W[i].cross(p_WP - kin.p_WJ[i]);
    J->block<3, 1>(kAngular, i) = kin.a_W[i];
  }
}

Vector7d Iiwa14Model::ClampToLimits(const Vector7d& q) const {
  return q.cwiseMax(config_.position_lower).cwiseMin(config_.position_upper);
}

bool Iiwa14Model::IsWithinLimits(const Vector7d& q, double tolerance) const {
  for (int i = 0; i < kIiwaNumJoints; ++i) {
    if (!(q[i] >= config_.position_lower[i] - tolerance) ||
        !(q[i] <= config_.position_upper[i] + tolerance)) {
      return false;
    }
  }
  return true;
}

Vector7d Iiwa14Model::CalcMidRange() const {
  return 0.5 * (config_.position_lower + config_.position_upper);
}

}  // namespace nsim
