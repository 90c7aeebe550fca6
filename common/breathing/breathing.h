#pragma once
// Semi-periodic respiratory motion: a Lujan-type cos^2n curve with cycle-to-cycle variation of
// amplitude and period, a superior-inferior dominant 3D direction with smaller antero-posterior
// and left-right components, and an optional linear baseline drift (DESIGN.md "Breathing").
//
// Lujan et al. (Med. Phys. 26(5), 1999) model the superior-inferior position as
//   z(t) = z0 - b cos^2n(pi t / tau - phi).
// Here the curve is written per cycle k (start T_k, period tau_k, amplitude factor a_k):
//   s(t) = a_k sin^2n(pi (t - T_k) / tau_k),   T_k <= t < T_k + tau_k,
// which is Lujan's curve with phi = pi/2 relative to each cycle start. Every cycle starts and ends
// at the exhale rest position (s = 0, ds/dt = 0), so redrawing a_k and tau_k per cycle leaves the
// motion continuous with a continuous velocity. The displacement from the exhale position is
//   d(t) = s(t) (A_si u_si + A_ap u_ap + A_lr u_lr) + v_drift t.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace nsim {

/// Parameters of the breathing generator. Defaults: liver motion of Liang 2018 (SI 11.9 mm,
/// AP 3.8 mm, LR 1.3 mm peak-to-peak, REFERENCE.md), a 4 s period, n = 2.
struct BreathingConfig {
  double period = 4.0;           ///< mean cycle period tau (s), > 0
  double period_cv = 0.1;        ///< std of the per-cycle period / mean period (-), in [0, 0.3]
  double amplitude_cv = 0.15;    ///< std of the per-cycle amplitude factor a_k (-), in [0, 0.3]
  double si_amplitude = 0.012;   ///< mean peak-to-peak superior-inferior amplitude A_si (m), >= 0
  double ap_amplitude = 0.0038;  ///< mean peak-to-peak antero-posterior amplitude A_ap (m), >= 0
  double lr_amplitude = 0.0013;  ///< mean peak-to-peak left-right amplitude A_lr (m), >= 0
  int shape_exponent = 2;        ///< n of cos^2n (-), in [1, 6]; larger = longer exhale rest
  double start_phase = 0.0;  ///< fraction of the first cycle already elapsed at t = 0 (-), [0, 1)
  /// Direction the liver moves on inhalation along each anatomical axis, world frame (unit after
  /// normalization; need not be orthogonal). Default: world z is superior, y anterior, x patient
  /// right (configs/meshes/README.md).
  Eigen::Vector3d axis_si = -Eigen::Vector3d::UnitZ();
  Eigen::Vector3d axis_ap = Eigen::Vector3d::UnitY();        ///< see axis_si
  Eigen::Vector3d axis_lr = Eigen::Vector3d::UnitX();        ///< see axis_si
  Eigen::Vector3d drift_velocity = Eigen::Vector3d::Zero();  ///< linear baseline drift (m/s)
  double horizon = 3600.0;   ///< the cycle table covers [0, horizon] (s), > 0
  uint64_t random_seed = 1;  ///< seed of the per-cycle draws (std::mt19937_64)

  /// Throws InputError naming the first invalid field, e.g.
  /// "breathing.period must be > 0 (s), got -1".
  void Validate() const;
};

/// One breathing cycle of the table.
struct BreathingCycle {
  double start = 0.0;             ///< T_k (s)
  double period = 0.0;            ///< tau_k (s)
  double amplitude_factor = 1.0;  ///< a_k (-), scales all three amplitudes
};

/// Immutable breathing model: the displacement d(t) for any t in [cycles().front().start,
/// horizon]. Deterministic given the config (including the seed); thread-safe to query.
class BreathingModel {
 public:
  /// Validates `config` (InputError) and draws the cycle table up to config.horizon. Per-cycle
  /// factors are normal with the configured relative std, truncated at 3 std.
  explicit BreathingModel(const BreathingConfig& config);

  /// Displacement from the exhale rest position at time t (m), world frame. Precondition:
  /// t_begin() <= t <= t_end() (checked). O(log #cycles), no allocation.
  Eigen::Vector3d CalcDisplacement(double t) const;

  /// Time derivative of CalcDisplacement (m/s); continuous across cycle boundaries.
  Eigen::Vector3d CalcVelocity(double t) const;

  /// Normalized shape s(t) = a_k sin^2n(pi (t - T_k) / tau_k) (-), 0 at exhale, a_k at inhale.
  double CalcShape(double t) const;

  /// Index of the cycle containing t (same precondition as CalcDisplacement).
  int FindCycle(double t) const;

  /// Displacement at full inhale with a_k = 1, drift excluded (m): sum of A_i u_i.
  const Eigen::Vector3d& peak_displacement() const { return peak_; }
  const std::vector<BreathingCycle>& cycles() const { return cycles_; }
  const BreathingConfig& config() const { return config_; }
  double t_begin() const { return cycles_.front().start; }
  double t_end() const { return config_.horizon; }

 private:
  BreathingConfig config_;
  Eigen::Vector3d peak_;
  std::vector<BreathingCycle> cycles_;
};

}  // namespace nsim
