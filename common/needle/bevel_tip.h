#pragma once
// Beveled needle tip loads after Misra et al. (thesis §2.1.2, eq. 2.1-2.3; §4.2):
//   a = d / tan(alpha),  b = d / sin(alpha),  e = d - a tan(beta) - (b / 3) sin(alpha),
//   P = P_input - K_T b^2 / 2 sin(alpha) tan(alpha - beta)                          (2.1)
//   Q = K_T a^2 / 2 tan(beta) - K_T b^2 / 2 cos(alpha) tan(alpha - beta)            (2.2)
//   M = K_T b^2 / 2 (b / 3 cos^2(alpha) - e sin(alpha)) tan(alpha - beta)
//       - K_T a^3 / 6 tan(beta)                                                      (2.3)
// with d the needle diameter, alpha the bevel angle, beta the cut angle (given as beta/alpha)
// and K_T the needle-tissue interaction stiffness (N/m^2). The loads are constant while the tip
// is in tissue.
//
// Bevel frame B at the tip: z_B = the needle direction at the tip (base to tip), y_B = the
// bevel side (the side a beveled needle curves towards), x_B = y_B x z_B; B is the tip frame
// rotated by bevel_angle about z. Sign convention (ours; Misra's figure fixes only magnitudes
// in a plane): the tissue acts on the needle tip with the transverse force Q y_B and the torque
// M x_B. With the thesis's parameters Q > 0 and M < 0, and both bend the needle towards +y_B (a
// torque -|M| x_B turns z_B towards +y_B). The thesis applies M only (§4.2.2): applying Q as
// well would count the tip load twice.

#include <Eigen/Core>
#include <string>

namespace nsim {

/// Which part of the Misra load the simulation applies.
enum class BevelLoadMode {
  kTorque,  ///< M only (thesis §4.2.2); a rigid needle, which cannot take a torque, applies Q
  kForce,   ///< Q only
};

/// Bevel tip parameters (thesis §5.3.1 defaults: table 5.3).
struct BevelConfig {
  bool enabled = false;            ///< false: symmetric tip, no load
  double diameter = 1.2e-3;        ///< d (m), > 0
  double bevel_angle = 0.2617;     ///< alpha (rad), in (0, pi/2)
  double beta_over_alpha = 0.9;    ///< beta / alpha (-), in [0, 1.5] (Misra: 0.25-1.0)
  double tissue_stiffness = 150e3; ///< K_T (N/m^2), > 0
  BevelLoadMode mode = BevelLoadMode::kTorque;

  /// Throws InputError "<prefix>.<key> must be ..., got <value>".
  void Validate(const std::string& prefix = "bevel") const;
};

/// Geometry and loads of eq. 2.1-2.3.
struct BevelLoads {
  double a = 0.0;        ///< d / tan(alpha) (m)
  double b = 0.0;        ///< d / sin(alpha) (m)
  double e = 0.0;        ///< d - a tan(beta) - (b/3) sin(alpha) (m)
  double beta = 0.0;     ///< cut angle (rad)
  /// Bevel part of the axial force, P - P_input = -K_T b^2/2 sin(alpha) tan(alpha - beta) (N);
  /// reported only: the axial load is set by the insertion (P_input).
  double p_bevel = 0.0;
  double q = 0.0;        ///< transverse force Q (N), eq. 2.2
  double m = 0.0;        ///< torque M (N m), eq. 2.3
};

/// Evaluates eq. 2.1-2.3 (config validated first; InputError). Independent of `enabled`.
BevelLoads CalcBevelLoads(const BevelConfig& config);

/// Bevel frame R_WB (columns x_B, y_B, z_B) from the tip frame R_WTip (z = needle direction)
/// and the bevel roll angle (rad): R_WB = R_WTip R_z(bevel_angle).
Eigen::Matrix3d CalcBevelFrame(const Eigen::Matrix3d& R_WTip, double bevel_angle);

/// World force (N) and torque (N m) the tissue applies to the needle tip for `mode`:
/// kTorque: (0, M x_B); kForce: (Q y_B, 0). Zero when the bevel is disabled.
void CalcBevelTipLoad(const BevelConfig& config, const BevelLoads& loads,
                      const Eigen::Matrix3d& R_WB, Eigen::Vector3d& f_W, Eigen::Vector3d& tau_W);

}  // namespace nsim
