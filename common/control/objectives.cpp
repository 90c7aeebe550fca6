#include "common/control/objectives.h"

#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {

Eigen::Vector3d CalcPositionObjective(const Eigen::Vector3d& p_WTarget,
                                      const Eigen::Vector3d& p_WTip) {
  return p_WTarget - p_WTip;
}

double CalcAngleObjective(const Eigen::Vector3d& n_tip_W, const Eigen::Vector3d& n_traj_W) {
  const double a = n_tip_W.norm();
  const double b = n_traj_W.norm();
  if (!(a > 0.0) || !(b > 0.0) || !std::isfinite(a) || !std::isfinite(b)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const Eigen::Vector3d n = n_tip_W / a;
  const Eigen::Vector3d m = n_traj_W / b;
  return std::atan2(n.cross(m).norm(), n.dot(m));
}

SkinPlane MakeSkinPlane(const Eigen::Vector3d& p_WP, const Eigen::Vector3d& n_W) {
  const double length = n_W.norm();
  if (!p_WP.allFinite() || !n_W.allFinite() || !(length > 0.0)) {
    throw InputError(Str("skin plane needs a finite point and a non-zero finite normal, got p = (",
                         p_WP.transpose(), "), n = (", n_W.transpose(), ")"));
  }
  SkinPlane plane;
  plane.p_WP = p_WP;
  plane.n_W = n_W / length;
  const Eigen::Vector3d seed =
      std::abs(plane.n_W.x()) > 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  plane.u_W = (seed - plane.n_W * plane.n_W.dot(seed)).normalized();
  plane.v_W = plane.n_W.cross(plane.u_W);
  return plane;
}

Eigen::Vector2d CalcEntryObjective(const SkinPlane& plane, const Eigen::Vector3d& p_Wc) {
  const Eigen::Vector3d d = p_Wc - plane.p_WP;
  return Eigen::Vector2d(plane.u_W.dot(d), plane.v_W.dot(d));
}

InsertionPhase DetermineInsertionPhase(bool skin_punctured, bool liver_punctured) {
  if (liver_punctured) return InsertionPhase::kInLiver;
  if (skin_punctured) return InsertionPhase::kInSkin;
  return InsertionPhase::kBeforeSkin;
}

ObjectiveLayout GetObjectiveLayout(InsertionPhase phase, bool align_in_liver, bool liver_load) {
  ObjectiveLayout layout;
  layout.position_row = 0;
  switch (phase) {
    case InsertionPhase::kBeforeSkin:
      layout.angle_row = 3;
      layout.rows = 4;
      break;
    case InsertionPhase::kInSkin:
      layout.angle_row = 3;
      layout.entry_row = 4;
      layout.rows = 6;
      break;
    case InsertionPhase::kInLiver:
      if (align_in_liver) {
        layout.angle_row = 3;
        layout.entry_row = 4;
        layout.rows = 6;
      } else {
        layout.entry_row = 3;
        layout.rows = 5;
      }
      if (liver_load) {
        layout.load_row = layout.rows;
        layout.rows += 2;
      }
      break;
  }
  NSIM_CHECK(layout.rows > 0, "unknown insertion phase ", static_cast<int>(phase));
  return layout;
}

void AssembleObjectiveVector(InsertionPhase phase, const ObjectiveValues& values,
                             Eigen::VectorXd* e, bool align_in_liver, bool liver_load) {
  const ObjectiveLayout layout = GetObjectiveLayout(phase, align_in_liver, liver_load);
  e->resize(layout.rows);
  e->segment<3>(layout.position_row) = values.e_p;
  if (layout.angle_row >= 0) (*e)[layout.angle_row] = values.e_a;
  if (layout.entry_row >= 0) e->segment<2>(layout.entry_row) = values.e_e;
  if (layout.load_row >= 0) e->segment<2>(layout.load_row) = values.e_l;
}

void ObjectiveGains::Validate() const {
  const double gains[4] = {position, angle, entry, load};
  const char* names[4] = {"position", "angle", "entry", "load"};
  for (int i = 0; i < 4; ++i) {
    if (!(gains[i] > 0.0 && gains[i] <= 1.0)) {
      throw InputError(Str("control.gains.", names[i], " must be in (0, 1], got ", gains[i]));
    }
  }
}

void AssembleGainVector(InsertionPhase phase, const ObjectiveGains& gains, Eigen::VectorXd* k,
                        bool align_in_liver, bool liver_load) {
  const ObjectiveLayout layout = GetObjectiveLayout(phase, align_in_liver, liver_load);
  k->resize(layout.rows);
  k->segment<3>(layout.position_row).setConstant(gains.position);
  if (layout.angle_row >= 0) (*k)[layout.angle_row] = gains.angle;
  if (layout.entry_row >= 0) k->segment<2>(layout.entry_row).setConstant(gains.entry);
  if (layout.load_row >= 0) k->segment<2>(layout.load_row).setConstant(gains.load);
}

}  // namespace nsim
