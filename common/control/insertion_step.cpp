#include "common/control/insertion_step.h"

#include <cmath>

namespace nsim {

double CalcNeedleAdvance(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& p_F,
                         const Eigen::Isometry3d& X_WF_from, const Eigen::Isometry3d& X_WF_to) {
  const Eigen::Vector3d a_W = X_WF_from.linear() * axis_F.normalized();
  return a_W.dot(X_WF_to * p_F - X_WF_from * p_F);
}

bool LimitNeedleAdvance(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& p_F,
                        const Eigen::Isometry3d& X_WF_from, double max_advance,
                        Eigen::Isometry3d* X_WF_to) {
  if (!(max_advance > 0.0) || !std::isfinite(max_advance)) return false;
  const double advance = CalcNeedleAdvance(axis_F, p_F, X_WF_from, *X_WF_to);
  if (!std::isfinite(advance) || advance <= max_advance) return false;
  // a translation along the axis moves every needle point by the same amount along it
  const Eigen::Vector3d a_W = X_WF_from.linear() * axis_F.normalized();
  X_WF_to->translation() -= (advance - max_advance) * a_W;
  return true;
}

}  // namespace nsim
