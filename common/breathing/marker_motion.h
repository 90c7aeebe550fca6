#pragma once
// Fiducial markers moving with a breathing model: marker m at base position p0_m moves as
//   p_m(t) = p0_m + g_m R_m d(t),
// with d(t) the BreathingModel displacement, g_m a gain that grows towards the diaphragm
// (superior markers move more) and R_m a small per-marker tilt of the motion direction.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "common/breathing/breathing.h"
#include "common/markers/marker_csv.h"

namespace nsim {

/// Placement and sampling of breathing markers.
struct MarkerMotionConfig {
  int num_markers = 5;  ///< number of markers (-), in [1, 100]
  /// Centre of the ellipsoid the base positions are drawn in, world frame (m).
  Eigen::Vector3d region_center = Eigen::Vector3d::Zero();
  /// Semi-axes of that ellipsoid along world x, y, z (m), all > 0. Default: the inner part of an
  /// adult liver (transverse ~21 cm, antero-posterior ~11 cm, craniocaudal ~16 cm, REFERENCE.md).
  Eigen::Vector3d region_semi_axes = Eigen::Vector3d(0.08, 0.04, 0.06);
  double min_gain = 0.6;   ///< gain at the most inferior point of the region (-), > 0
  double max_gain = 1.0;   ///< gain at the most superior point (-), >= min_gain
  double max_tilt = 0.15;  ///< largest per-marker rotation of the motion direction (rad), [0, 0.5]
  double rate = 30.0;      ///< sampling rate of the stream (Hz), > 0
  double duration = 60.0;  ///< stream duration (s), > 0; frames at t = k / rate, t <= duration
  uint64_t random_seed = 1;  ///< seed of the placement and tilt draws (std::mt19937_64)

  /// Throws InputError naming the first invalid field, e.g. "markers.rate must be > 0 (Hz), got 0".
  void Validate() const;
};

/// Per-marker motion parameters drawn from a MarkerMotionConfig (#markers entries each).
struct MarkerMotion {
  std::vector<Eigen::Vector3d> p0_W;    ///< base (exhale) positions in world (m)
  std::vector<double> gain;             ///< g_m (-)
  std::vector<Eigen::Matrix3d> R_tilt;  ///< R_m, rotation applied to d(t) (-)
};

/// Draws base positions uniformly inside the ellipsoid, gains by height along the superior
/// direction (opposite to `model.config().axis_si`) and tilts with a uniform random axis and a
/// uniform angle in [0, max_tilt]. Validates `config` (InputError).
MarkerMotion MakeMarkerMotion(const BreathingModel& model, const MarkerMotionConfig& config);

/// Position of marker m at time t (m), world frame: p0_m + g_m R_m d(t).
Eigen::Vector3d CalcMarkerPosition(const BreathingModel& model, const MarkerMotion& motion, int m,
                                   double t);

/// Samples all markers at t = k / config.rate, k = 0 .. floor(duration * rate). Frames carry
/// seq = k and sim_time = t (wall_time_ns = 0). Throws InputError if the duration exceeds the
/// breathing model's horizon.
MarkerStream MakeBreathingMarkerStream(const BreathingModel& model,
                                       const MarkerMotionConfig& config);

}  // namespace nsim
