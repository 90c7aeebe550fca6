#pragma once
// The constraint objective functions of the inverse simulation (thesis §3.3, eq. 3.3-3.5) as
// pure functions, and the insertion phases of fig. 3.3 that select which of them are active.
//
// Row layout of the objective vector e (and of the Jacobian's rows), fixed order
// [e_p (3) | e_a (1) | e_e (2)] with inactive blocks left out:
//   phase 1, before the skin:        [e_p, e_a]       4 rows
//   phase 2, in the skin, not liver: [e_p, e_a, e_e]  6 rows
//   phase 3, in the liver:           [e_p, e_e]       5 rows
//   phase 3 aligned (align_in_liver): [e_p, e_a, e_e] 6 rows: a flexible needle's direction,
//     which e_p and e_e do not fix in the liver (SteeringControlConfig::liver_alignment)
//   phase 3 with the liver's load (liver_load): e_l (2) appended after the others, 7 or 8
//     rows: the lateral force of the liver on the needle as the needle's lateral displacement
//     that would remove it (SteeringControlConfig::liver_load)

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace nsim {

/// Thesis eq. 3.3: e_p = q_target - q_tip, the tip-to-target vector in world (m).
Eigen::Vector3d CalcPositionObjective(const Eigen::Vector3d& p_WTarget,
                                      const Eigen::Vector3d& p_WTip);

/// Thesis eq. 3.4: e_a = arccos(n_tip . n_traj) (rad, in [0, pi]), the angle between the
/// needle direction and the trajectory tangent at the skin entry. Inputs need not be unit
/// (both are normalized; zero or non-finite input gives NaN). Computed as
/// atan2(|n x m|, n . m), mathematically equal to arccos of the normalized dot product but
/// accurate everywhere: arccos has an infinite slope at 1, so near alignment a rounding error
/// eps in the dot product becomes an angle error sqrt(2 eps) (1.5e-8 rad for eps = 1.1e-16,
/// while the true angle may be 1e-12); atan2 keeps the relative precision of the cross
/// product. The function itself is |angle|, a cone with a kink at 0: its gradient has unit
/// norm everywhere except at exact alignment, where a central difference of step h returns a
/// too-small slope for angles below about h. That is a property of eq. 3.4, not of the
/// evaluation.
double CalcAngleObjective(const Eigen::Vector3d& n_tip_W, const Eigen::Vector3d& n_traj_W);

/// The skin plane P of eq. 3.5 at the puncture: a point, the unit normal and a right-handed
/// in-plane basis (u, v, n). u is the world x axis projected onto the plane (the world y axis if
/// x is within ~25 degrees of the normal, |n . x| > 0.9), v = n x u.
struct SkinPlane {
  Eigen::Vector3d p_WP = Eigen::Vector3d::Zero();  ///< puncture point p_p in world (m)
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal of the skin at p_p
  Eigen::Vector3d u_W = Eigen::Vector3d::UnitX();  ///< first in-plane unit axis
  Eigen::Vector3d v_W = Eigen::Vector3d::UnitY();  ///< second in-plane unit axis, n x u
};

/// Builds the skin plane at the puncture point p_WP (m) with normal n_W (any length > 0).
/// Throws InputError on a non-finite input or a zero normal.
SkinPlane MakeSkinPlane(const Eigen::Vector3d& p_WP, const Eigen::Vector3d& n_W);

/// Thesis eq. 3.5: e_e = proj_P(p_c - p_p), the motion of the current entry point p_c since the
/// puncture, projected onto the skin plane, as [u . d; v . d] (m) in the plane's basis.
Eigen::Vector2d CalcEntryObjective(const SkinPlane& plane, const Eigen::Vector3d& p_Wc);

/// Insertion phases of fig. 3.3 (thesis numbering; SimStatus::phase uses phase - 1).
enum class InsertionPhase : uint8_t {
  kBeforeSkin = 1,  ///< needle outside the patient: e_p, e_a
  kInSkin = 2,      ///< skin punctured, liver not: e_p, e_a, e_e
  kInLiver = 3,     ///< liver punctured: e_p, e_e
};

/// The phase from the puncture flags of the needle model: the liver flag wins (the needle
/// reaches the liver through the skin).
InsertionPhase DetermineInsertionPhase(bool skin_punctured, bool liver_punctured);

/// Which objectives are active in a phase and where their rows start (-1 if inactive).
struct ObjectiveLayout {
  int rows = 0;          ///< total rows: 4, 6 or 5
  int position_row = 0;  ///< first row of e_p (always active)
  int angle_row = -1;    ///< row of e_a
  int entry_row = -1;    ///< first row of e_e
  int load_row = -1;     ///< first row of e_l
};

/// The layout of a phase (see the file comment); align_in_liver keeps e_a in phase 3,
/// liver_load adds e_l there.
ObjectiveLayout GetObjectiveLayout(InsertionPhase phase, bool align_in_liver = false,
                                   bool liver_load = false);

/// All objective values at one configuration; e_e is ignored before the puncture.
struct ObjectiveValues {
  Eigen::Vector3d e_p = Eigen::Vector3d::Zero();  ///< eq. 3.3 (m)
  double e_a = 0.0;                               ///< eq. 3.4 (rad)
  Eigen::Vector2d e_e = Eigen::Vector2d::Zero();  ///< eq. 3.5 (m)
  /// The liver's lateral load on the needle as a displacement (m): K_t^-1 [t_1 t_2]^T F, F the
  /// liver's resultant force on the needle, t_1, t_2 across the needle, K_t the liver's 2 x 2
  /// lateral stiffness against the needle's translation (SteeringController).
  Eigen::Vector2d e_l = Eigen::Vector2d::Zero();
};

/// Stacks the active objectives of `phase` into e (resized to the layout's rows).
void AssembleObjectiveVector(InsertionPhase phase, const ObjectiveValues& values,
                             Eigen::VectorXd* e, bool align_in_liver = false,
                             bool liver_load = false);

/// Control gains per objective (the vector k of eq. 3.9 / A.3 repeats each on its rows).
struct ObjectiveGains {
  double position = 0.5;  ///< gain on e_p rows, in (0, 1]
  double angle = 0.5;     ///< gain on the e_a row, in (0, 1]
  double entry = 0.5;     ///< gain on e_e rows, in (0, 1]
  double load = 0.5;      ///< gain on e_l rows, in (0, 1]

  /// Throws InputError naming the first gain outside (0, 1], e.g.
  /// "control.gains.angle must be in (0, 1], got 0".
  void Validate() const;
};

/// The per-row gain vector k of `phase` (resized to the layout's rows).
void AssembleGainVector(InsertionPhase phase, const ObjectiveGains& gains, Eigen::VectorXd* k,
                        bool align_in_liver = false, bool liver_load = false);

}  // namespace nsim
