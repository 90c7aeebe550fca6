#include "common/control/needle_tilt.h"

#include <algorithm>
#include <cmath>

namespace nsim {

double CalcNeedleTilt(const Eigen::Isometry3d& X_WF, const Eigen::Vector3d& axis_F,
                      const Eigen::Vector3d& direction_W) {
  const Eigen::Vector3d a = (X_WF.linear() * axis_F).normalized();
  const Eigen::Vector3d d = direction_W.normalized();
  // atan2 of |a x d| and a . d: accurate near 0 and pi, where acos of the dot is not
  return std::atan2(a.cross(d).norm(), a.dot(d));
}

bool LimitNeedleTilt(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& direction_W,
                     const Eigen::Vector3d& pivot_W, double max_tilt, Eigen::Isometry3d* X_WF) {
  if (!X_WF->matrix().allFinite() || !axis_F.allFinite() || !direction_W.allFinite() ||
      !pivot_W.allFinite() || !(max_tilt > 0.0))
    return false;
  const double tilt = CalcNeedleTilt(*X_WF, axis_F, direction_W);
  if (!(tilt > max_tilt)) return false;
  const Eigen::Vector3d a = (X_WF->linear() * axis_F).normalized();
  const Eigen::Vector3d d = direction_W.normalized();
  Eigen::Vector3d n = a.cross(d);
  if (n.norm() < 1e-12) {
    // antiparallel: any axis normal to the needle turns it toward d
    n = a.unitOrthogonal();
  }
  n.normalize();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(tilt - max_tilt, n).toRotationMatrix();
  X_WF->linear() = R * X_WF->linear();
  X_WF->translation() = pivot_W + R * (X_WF->translation() - pivot_W);
  return true;
}

}  // namespace nsim
