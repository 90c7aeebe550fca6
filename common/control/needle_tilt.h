#pragma once
// The bound on the needle's tilt: the angle between the commanded needle axis and the planned
// insertion direction (entry -> target, a straight path).
//
// Why: in the liver the objectives are e_p and e_e (objectives.h), which fix a rigid needle's
// direction (the line through the entry point and the tip) but not a flexible one's. Held by
// the tissue, a bent needle lets its base turn about the entry point with hardly any effect on
// the tip; whatever e_p the model cannot remove then keeps turning it, step after step (the
// regularized inverse caps each step, not their sum). On the default scenario the flexible
// needle's base turned 55-63 degrees inside the liver over 20 s, bending the needle and
// dragging both livers (README "Flexible and bevelled needles"). The rigid needle tilts
// 11-19 degrees while it follows the breathing during the insertion.
//
// A commanded flange pose whose needle axis is tilted more than the bound is turned back onto
// the bound's cone about the pivot (the needle's entry point in the skin, so the needle still
// passes it), by the smallest rotation: about the axis normal to the needle and the planned
// direction. Within the bound the pose is returned unchanged (bit for bit).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace nsim {

/// The angle (rad, [0, pi]) between the needle axis of flange pose X_WF (axis_F, the needle's
/// direction in the flange frame) and the planned direction direction_W (need not be unit).
double CalcNeedleTilt(const Eigen::Isometry3d& X_WF, const Eigen::Vector3d& axis_F,
                      const Eigen::Vector3d& direction_W);

/// Turns *X_WF about pivot_W so that its needle tilt is at most max_tilt (rad, > 0); returns
/// whether it turned it. A needle pointing exactly against direction_W (tilt pi, no unique
/// turn) is turned about an axis normal to it (Eigen's unitOrthogonal); non-finite input and
/// max_tilt <= 0 leave it unchanged (false).
bool LimitNeedleTilt(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& direction_W,
                     const Eigen::Vector3d& pivot_W, double max_tilt, Eigen::Isometry3d* X_WF);

}  // namespace nsim
