#include "common/needle/rigid_needle.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {

void NeedleConfig::Validate(const std::string& prefix) const {
  auto positive = [&](double value, const char* key, const char* unit) {
    if (!(value > 0.0) || !std::isfinite(value))
      throw InputError(Str(prefix, ".", key, " must be > 0 (", unit, "), got ", value));
  };
  positive(length, "length", "m");
  positive(radius, "radius", "m");
  positive(young_modulus, "young_modulus", "Pa");
  positive(density, "density", "kg/m^3");
  // biopsy needles are 5..30 cm long and 0.2..2 mm in radius; 2 m and 5 cm are no needles;
  // the stiffest and densest solids: 1.2e12 Pa (diamond), 2.3e4 kg/m^3 (osmium)
  CheckAtMost(length, 2.0, prefix + ".length", "m");
  CheckAtMost(radius, 0.05, prefix + ".radius", "m");
  CheckAtMost(young_modulus, 1e12, prefix + ".young_modulus", "Pa");
  CheckAtMost(density, 1e5, prefix + ".density", "kg/m^3");
  if (!(poisson_ratio > -1.0 && poisson_ratio < 0.5))
    throw InputError(Str(prefix, ".poisson_ratio must be in (-1, 0.5), got ", poisson_ratio));
  if (!p_FBase.allFinite())
    throw InputError(Str(prefix, ".p_FBase must be finite (m), got ", p_FBase.transpose()));
  if (!axis_F.allFinite() || !(axis_F.norm() > 1e-12))
    throw InputError(Str(prefix, ".axis_F must be a finite nonzero vector, got ", axis_F.transpose()));
  if (radius >= length)
    throw InputError(Str(prefix, ".radius must be < ", prefix, ".length (", length, " m), got ",
                         radius));
}

Eigen::Isometry3d CalcToolOffset(const NeedleConfig& config) {
  const Eigen::Vector3d z = config.axis_F.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z.x() * z;
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - z.y() * z;
  x.normalize();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = config.p_FBase;
  return X;
}

RigidNeedleModel::RigidNeedleModel(const NeedleConfig& config) : config_(config) {
  config_.Validate("needle");
  X_FN_ = CalcToolOffset(config_);
}

void ResetRigidNeedle(const RigidNeedleModel& model, const Eigen::Isometry3d& X_WF,
                      RigidNeedleState& state) {
  state.X_WN_start = model.CalcNeedlePose(X_WF);
  state.X_WN_end = state.X_WN_start;
}

void SetRigidNeedleTarget(const RigidNeedleModel& model, const Eigen::Isometry3d& X_WF,
                          RigidNeedleState& state) {
  if (!X_WF.matrix().allFinite())
    throw InputError("needle: flange pose X_WF must be finite, got a NaN or inf");
  state.X_WN_end = model.CalcNeedlePose(X_WF);
}

void AdvanceRigidNeedle(RigidNeedleState& state) { state.X_WN_start = state.X_WN_end; }

Eigen::Matrix3d RotationZ(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

double CalcSecondMomentOfArea(double radius) { return M_PI * std::pow(radius, 4) / 4.0; }

}  // namespace nsim
