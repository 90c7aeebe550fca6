#include "common/needle/bevel_tip.h"

#include <Eigen/Geometry>
#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {

void BevelConfig::Validate(const std::string& prefix) const {
  if (!(diameter > 0.0) || !std::isfinite(diameter))
    throw InputError(Str(prefix, ".diameter must be > 0 (m), got ", diameter));
  if (!(bevel_angle > 0.0 && bevel_angle < M_PI / 2))
    throw InputError(Str(prefix, ".bevel_angle must be in (0, pi/2) (rad), got ", bevel_angle));
  if (!(beta_over_alpha >= 0.0 && beta_over_alpha <= 1.5))
    throw InputError(Str(prefix, ".beta_over_alpha must be in [0, 1.5], got ", beta_over_alpha));
  if (!(beta_over_alpha * bevel_angle < M_PI / 2))
    throw InputError(Str(prefix, ".beta_over_alpha * bevel_angle must be < pi/2 (rad), got ",
                         beta_over_alpha * bevel_angle));
  if (!(tissue_stiffness > 0.0) || !std::isfinite(tissue_stiffness))
    throw InputError(Str(prefix, ".tissue_stiffness must be > 0 (N/m^2), got ", tissue_stiffness));
  // a needle is at most a few mm across (10 cm is none); a tissue stiffer than diamond
  // (1.2e12) is none
  CheckAtMost(diameter, 0.1, prefix + ".diameter", "m");
  CheckAtMost(tissue_stiffness, 1e12, prefix + ".tissue_stiffness", "N/m^2");
}

BevelLoads CalcBevelLoads(const BevelConfig& config) {
  config.Validate();
  const double d = config.diameter, alpha = config.bevel_angle, kt = config.tissue_stiffness;
  BevelLoads l;
  l.beta = config.beta_over_alpha * alpha;
  l.a = d / std::tan(alpha);
  l.b = d / std::sin(alpha);
  l.e = d - l.a * std::tan(l.beta) - l.b / 3.0 * std::sin(alpha);
  const double t_ab = std::tan(alpha - l.beta);
  const double kb2 = kt * l.b * l.b / 2.0;
  // eq. 2.1-2.3
  l.p_bevel = -kb2 * std::sin(alpha) * t_ab;
  l.q = kt * l.a * l.a / 2.0 * std::tan(l.beta) - kb2 * std::cos(alpha) * t_ab;
  l.m = kb2 * (l.b / 3.0 * std::cos(alpha) * std::cos(alpha) - l.e * std::sin(alpha)) * t_ab -
        kt * l.a * l.a * l.a / 6.0 * std::tan(l.beta);
  return l;
}

Eigen::Matrix3d CalcBevelFrame(const Eigen::Matrix3d& R_WTip, double bevel_angle) {
  return R_WTip * Eigen::AngleAxisd(bevel_angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void CalcBevelTipLoad(const BevelConfig& config, const BevelLoads& loads,
                      const Eigen::Matrix3d& R_WB, Eigen::Vector3d& f_W, Eigen::Vector3d& tau_W) {
  f_W.setZero();
  tau_W.setZero();
  if (!config.enabled) return;
  if (config.mode == BevelLoadMode::kTorque)
    tau_W = loads.m * R_WB.col(0);
  else
    f_W = loads.q * R_WB.col(1);
}

}  // namespace nsim
