#pragma once
// The gelatin-block bevel scenario of thesis §5.3.1 (fig. 5.10): a flexible beveled needle is
// pushed along +X into the centre of one face of a gelatin prism and deflects in Y.
//
// Material values: the thesis text gives gelatin E = 5 GPa and needle E = 43.26 kPa, which are
// swapped (a 5 GPa gel would be stiffer than the needle); we use gelatin E = 43.26 kPa (inside
// the 10-50 kPa range of gelatin phantoms) and needle E = 5 GPa (the flexible needle of §5.3).
// The prism size is not given; we take 14.5 x 7 x 2 cm (5 mm node spacing on the 30 x 15 x 5
// grid), bottom face (z = 0) and far face (x = max) fixed: a phantom resting in a container.
// Gravity is off: the phantom's weight rests on its support and does not change Y deflection.

#include <Eigen/Core>

#include "common/fem/fem_config.h"
#include "common/needle/beam_needle.h"
#include "common/needle/bevel_tip.h"
#include "common/needle/needle_tissue.h"

namespace nsim {

/// Gelatin FEM defaults: E 43.26 kPa, nu 0.45 (thesis), rho 1000 kg/m^3, h 20 ms, no gravity.
FemConfig MakeGelatinFemConfig();
/// Bevel defaults of table 5.3: d 1.2 mm, alpha 0.2617 rad, K_T 150 kPa, beta/alpha 0.9, on.
BevelConfig MakeGelatinBevelConfig();
/// Needle-gelatin coupling defaults: Delta l_c = 3.5 cm (thesis fit), puncture 0.05 N,
/// friction mu 0.1.
TissueCouplingConfig MakeGelatinCouplingConfig();

/// The scenario (SI units). Defaults match thesis §5.3.1 where it gives values.
struct GelatinBevelScenarioConfig {
  Eigen::Vector3i block_nodes{30, 15, 5};       ///< grid nodes along x, y, z (-), each >= 2
  Eigen::Vector3d block_size{0.145, 0.07, 0.02}; ///< prism size (m), origin at 0
  FemConfig gelatin = MakeGelatinFemConfig();
  BeamNeedleConfig needle;                      ///< 20 cm, r 0.6 mm, E 5 GPa, 20 elements
  BevelConfig bevel = MakeGelatinBevelConfig();
  TissueCouplingConfig coupling = MakeGelatinCouplingConfig();
  double bevel_angle = 0.0;         ///< bevel roll (rad): 0 = bevel side +Y, pi = -Y
  double initial_gap = 2e-3;        ///< tip to the block face at the start (m), > 0
  double insertion_speed = 0.05;    ///< base speed along +X (m/s), > 0
  double insertion_depth = 0.10;    ///< base travel beyond the gap (m), > 0, < needle length

  /// Throws InputError "gelatin.<key> must be ..., got <value>".
  void Validate() const;
};

/// Outcome of a run.
struct GelatinBevelResult {
  double tip_deflection_y = 0.0;  ///< tip Y minus the insertion line's Y at the end (m)
  double tip_deflection_z = 0.0;  ///< same in Z (m)
  double depth = 0.0;             ///< needle length inside the gelatin at the end (m)
  bool punctured = false;
  double puncture_time = 0.0;     ///< (s)
  int num_points = 0;             ///< constraint points at the end
  int steps = 0;
  double max_solver_violation = 0.0;  ///< largest row violation over the run (m)
  double bevel_q = 0.0, bevel_m = 0.0;  ///< Misra Q (N) and M (N m) used
};

/// Runs the insertion (validates the config; InputError). Deterministic.
GelatinBevelResult RunGelatinBevelScenario(const GelatinBevelScenarioConfig& config);

}  // namespace nsim
