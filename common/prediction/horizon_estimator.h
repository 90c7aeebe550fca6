#pragma once
// Prediction-horizon estimation (thesis §4.1.3): an order-1 filter on the control loop's past
// timestamps predicts the time of the next loop (eq. 4.8-4.9); the horizon adds the marker
// localization delay (eq. 4.10).

#include <vector>

namespace nsim {

/// Settings of the horizon estimator.
struct HorizonConfig {
  int history = 60;                 ///< loop timestamps kept (samples), >= window_max + 2
  int window = 10;                  ///< regression window WF of eq. 4.8 (samples), >= 2
  bool optimize_window = false;     ///< choose WF by golden search (Algorithm 1 on timestamps)
  int window_max = 30;              ///< search range [2, window_max - 1] (samples)
  int search_interval = 0;          ///< rerun the search every this many timestamps; 0 = once
  double localization_delay = 0.0;  ///< delta tau_loc of eq. 4.10 (s), >= 0

  /// Throws InputError naming the first invalid field ("horizon.window must be >= 2, got 1").
  void Validate() const;
};

/// Estimates the next loop time and the prediction horizon. Preallocated; AddLoopTime and
/// CalcHorizon do not allocate (a window search, when due, does not either).
class HorizonEstimator {
 public:
  /// Validates `config` (InputError).
  explicit HorizonEstimator(const HorizonConfig& config);

  /// Records the time a control loop started (s). Throws InputError if t is not finite or does
  /// not increase.
  void AddLoopTime(double t);

  /// Predicted time of the next loop t^(WF+1) (s), eq. 4.9: a least-squares line through the
  /// last WF timestamps against their index, evaluated one index later. With fewer than WF
  /// timestamps all are used; with one, it is returned; with none, NaN.
  double PredictNextLoopTime();

  /// Horizon for a marker sample taken at t_sample (s): h = t^(WF+1) - t_sample + delta tau_loc
  /// (eq. 4.10 written relative to the sample, so h is a duration), clamped at >= 0.
  double CalcHorizon(double t_sample);

  int window() const { return window_; }
  int size() const { return size_; }

 private:
  void CopyChronological(int count);  // the newest `count` times into times_

  HorizonConfig config_;
  std::vector<double> ring_;   // history (s)
  std::vector<double> times_;  // chronological scratch (s)
  std::vector<double> index_;  // 0, 1, 2, ... regression abscissa of eq. 4.8
  int head_ = 0, size_ = 0;
  int window_;
  int since_search_ = 0;
  bool searched_ = false;
};

}  // namespace nsim
