#pragma once
// Kalman filter on a harmonic (truncated Fourier series) breathing model, a literature baseline
// for the polynomial filter.
//
// The signal is modelled as y(t) = c(t) + sum_k Re z_k(t), k = 1..K, where c is a slowly varying
// baseline and z_k = p_k + i q_k is the phasor of the k-th harmonic of the breathing frequency
// w, rotating as z_k(t + dt) = z_k(t) e^{i k w dt}. This is the Fourier linear combiner model of
// Vaz & Thakor (IEEE TBME 36(4), 1989) and Riviere, Rader & Thakor (IEEE TBME 45(5), 1998, the
// weighted-frequency FLC for physiological tremor); estimating its state with a Kalman filter
// and random-walk process noise on c and every z_k follows Veluvolu & Ang (IEEE TBME 58(1),
// 2011, KF-BMFLC). Extrapolating to t + h rotates each phasor by k w h. The frequency w comes
// from the autocorrelation of a recent window (EstimatePeriod), re-estimated on a schedule.
// A cos^2n breathing cycle (Lujan) has exactly harmonics 1..n of w, so K = n fits it exactly.

#include <Eigen/Core>

namespace nsim {

/// Largest number of harmonics K the filter supports.
constexpr int kMaxHarmonics = 3;

/// Noise and model settings of a HarmonicKalman.
struct HarmonicKalmanParams {
  int harmonics = 2;                                ///< K, in [1, kMaxHarmonics]
  double omega = 2 * 3.14159265358979323846 / 4.0;  ///< breathing frequency w (rad/s), > 0
  double measurement_variance = 1e-10;              ///< R (y units^2), > 0
  double baseline_diffusion = 1e-8;  ///< random-walk intensity of c (y units^2 / s), >= 0
  double harmonic_diffusion = 1e-6;  ///< same, of p_k and q_k (y units^2 / s), >= 0
};

/// Kalman filter over the state x = (c, p_1, q_1, ..., p_K, q_K). Fixed-capacity storage: no
/// allocation after construction.
class HarmonicKalman {
 public:
  HarmonicKalman();

  /// Sets the model and resets the state to x = (y0, 0, ...), with variance `initial_variance`
  /// (y units^2) on every state.
  void Reset(const HarmonicKalmanParams& params, double y0, double initial_variance);

  /// Changes w, R and the diffusions, keeping the state and its covariance (retuning).
  void SetParams(const HarmonicKalmanParams& params);

  /// Propagates the state by dt (s, >= 0) and corrects it with the measurement y.
  void Update(double dt, double y);

  /// Predicted signal at the last update time + h (s): c + sum_k Re(z_k e^{i k w h}).
  double Predict(double h) const;

  const HarmonicKalmanParams& params() const { return params_; }
  int state_size() const { return 1 + 2 * params_.harmonics; }

 private:
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                               1 + 2 * kMaxHarmonics, 1 + 2 * kMaxHarmonics>;
  using Vector =
      Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 1 + 2 * kMaxHarmonics, 1>;
  void Propagate(double dt);

  HarmonicKalmanParams params_;
  Vector x_;
  Matrix P_, F_, scratch_;
};

/// Breathing period (s) of n samples (t_i, y_i) from the first strong peak of the
/// autocorrelation over lags in [min_period, max_period]: at each lag L the Pearson correlation
/// of y[0, n-L) with y[L, n) (samples treated as uniformly spaced at their mean interval; the
/// peak refined by a parabola). Lags are limited to 2n/3 so each correlation averages at least
/// n/3 products. A peak must reach 0.3 and rise 0.3 above the lowest correlation at shorter
/// lags; returns NaN when there is none (e.g. a trend without oscillation).
/// No allocation.
double EstimatePeriod(const double* t, const double* y, int n, double min_period,
                      double max_period);

/// Measurement-noise variance of n uniformly sampled values from their fourth differences:
/// mean((y_{i-2} - 4 y_{i-1} + 6 y_i - 4 y_{i+1} + y_{i+2})^2) / 70, exact for white noise on a
/// locally cubic signal; a smooth breathing signal adds only its fourth derivative times dt^4
/// (y units^2). Precondition n >= 5.
double EstimateNoiseVariance(const double* y, int n);

}  // namespace nsim
