#pragma once
// Marker-position prediction for the inverse simulation (thesis §4.1, fig. 4.2 and 4.4): one
// filter per fiducial marker, chosen by config, behind a common interface.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "common/core/samples.h"
#include "common/prediction/pca_buffer.h"

namespace nsim {

/// Which predictor runs on each marker.
enum class PredictionFilterKind {
  kNone,            ///< no prediction: the last sample (the "delayed signal" of eq. 4.20)
  kLinear,          ///< PCA + polynomial linear filter, LF (thesis §4.1.1-4.1.4)
  kHarmonicKalman,  ///< PCA + Kalman filter on a harmonic breathing model (harmonic_kalman.h)
};

/// "none", "lf" or "kalman" -> kind; throws InputError "prediction.filter must be one of ...".
PredictionFilterKind ParsePredictionFilter(const std::string& name);
/// kind -> "none", "lf" or "kalman".
std::string ToString(PredictionFilterKind kind);

/// Settings of the marker predictors. Sample counts refer to marker frames.
struct PredictionConfig {
  PredictionFilterKind filter = PredictionFilterKind::kLinear;  ///< predictor per marker
  int pca_window = 300;  ///< WP: PCA rolling buffer (samples), >= 3
  /// Recompute the mean and D1 every this many samples once the buffer is full; 0 = only once,
  /// when it first fills (the thesis's preparation phase).
  int pca_update_interval = 1;
  int order = 2;                ///< LF polynomial order (eq. 4.2: 1, eq. 4.5: 2), in [1, 3]
  int window = 10;              ///< WF, LF regression window when not optimized (samples)
  bool optimize_window = true;  ///< choose WF by golden search (Algorithm 1, eq. 4.11-4.18)
  int window_max = 60;          ///< WL: the search covers [order+1, WL-1] (samples)
  /// Rerun the WF search (LF) or the period estimate (Kalman) every this many samples after the
  /// buffer is full; 0 = only once, when it first fills.
  int search_interval = 0;
  int search_lead = 1;                 ///< samples ahead the search cost predicts (Algorithm 1: 1)
  int kalman_harmonics = 2;            ///< K harmonics of the Kalman model, in [1, 3]
  double kalman_min_period = 1.5;      ///< shortest breathing period searched (s), > 0
  double kalman_max_period = 8.0;      ///< longest breathing period searched (s), > min
  double kalman_nominal_period = 4.0;  ///< period used when no period is detected (s), > 0
  /// Random-walk intensity of each harmonic phasor, as a fraction of the buffer's PC std per
  /// sqrt(second) (1/sqrt(s)), >= 0.
  double kalman_harmonic_walk = 0.3;
  double kalman_baseline_walk = 0.05;  ///< same for the baseline (1/sqrt(s)), >= 0
  /// Measurement noise std of the PC (m); 0 = estimated from the buffer's second differences.
  double kalman_measurement_std = 0.0;

  /// Throws InputError naming the first invalid field, e.g.
  /// "prediction.window must be >= order+1 (3), got 1".
  void Validate() const;
};

/// One marker's predictor. Update and Predict do not allocate.
class MarkerFilter {
 public:
  virtual ~MarkerFilter() = default;
  /// Adds the measured position p (m, world) at time t (s). The caller guarantees finite
  /// values and strictly increasing t (MarkerPredictor checks).
  virtual void Update(double t, const Eigen::Vector3d& p) = 0;
  /// Predicted position at (time of the last update) + horizon (m); horizon (s) >= 0. Before
  /// ready(), the last measured position (no prediction).
  virtual Eigen::Vector3d Predict(double horizon) = 0;
  /// True once the filter predicts (LF and Kalman: once the PCA buffer is full).
  virtual bool ready() const = 0;
  /// Regression window WF in use (samples); 0 for filters without one.
  virtual int window() const { return 0; }
  /// Principal axes in use, or nullptr for filters without PCA or before ready().
  virtual const PrincipalAxes* axes() const { return nullptr; }
  /// Frames ahead the window search scores (PredictionConfig::search_lead), for a horizon
  /// measured while running; filters without a window search ignore it.
  virtual void SetSearchLead(int /*samples*/) {}
};

/// Makes the filter `config.filter` for one marker. Validates `config` (InputError).
std::unique_ptr<MarkerFilter> MakeMarkerFilter(const PredictionConfig& config);

/// Predicts every marker of a frame (thesis fig. 4.4: the inverse simulation registers to
/// the predicted markers). All storage is allocated at construction.
class MarkerPredictor {
 public:
  /// Validates `config` (InputError); num_markers >= 1.
  MarkerPredictor(const PredictionConfig& config, int num_markers);

  /// Feeds one frame. Throws InputError if its marker count differs, a value is not finite or
  /// its sim_time does not increase; the predictor is unchanged then.
  void Update(const MarkerFrame& frame);

  /// Predicted positions at (last frame time) + horizon into p_WM (#markers, m). p_WM is
  /// resized only if its size differs. Throws InputError if horizon is negative or not finite.
  void Predict(double horizon, std::vector<Eigen::Vector3d>* p_WM);

  /// True once every marker's filter predicts.
  bool ready() const;
  /// Sets every filter's search lead to `samples`, >= 1, bounded so that the search still fits
  /// the PCA window (pca_window - window_max); used when the horizon is measured.
  void SetSearchLead(int samples);
  int num_markers() const { return static_cast<int>(filters_.size()); }
  const MarkerFilter& filter(int m) const { return *filters_[m]; }
  const PredictionConfig& config() const { return config_; }
  /// Time of the last accepted frame (s); NaN before the first.
  double last_time() const { return last_time_; }

 private:
  PredictionConfig config_;
  std::vector<std::unique_ptr<MarkerFilter>> filters_;
  double last_time_;
};

}  // namespace nsim
