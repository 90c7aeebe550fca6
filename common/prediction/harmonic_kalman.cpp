#include "common/prediction/harmonic_kalman.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {

HarmonicKalman::HarmonicKalman() {
  const int m = 1 + 2 * kMaxHarmonics;
  x_.setZero(m);
  P_.setZero(m, m);
  F_.setZero(m, m);
  scratch_.setZero(m, m);
}

void HarmonicKalman::SetParams(const HarmonicKalmanParams& params) {
  NSIM_CHECK(params.harmonics == params_.harmonics, "SetParams cannot change the harmonics");
  NSIM_CHECK(params.omega > 0 && params.measurement_variance > 0, "invalid Kalman parameters");
  params_ = params;
}

void HarmonicKalman::Reset(const HarmonicKalmanParams& params, double y0, double initial_variance) {
  NSIM_CHECK(params.harmonics >= 1 && params.harmonics <= kMaxHarmonics, "harmonics out of range");
  NSIM_CHECK(params.omega > 0 && params.measurement_variance > 0, "invalid Kalman parameters");
  params_ = params;
  const int m = state_size();
  x_.setZero(m);
  x_[0] = y0;
  P_.setIdentity(m, m);
  P_ *= initial_variance;
  F_.setZero(m, m);
  scratch_.setZero(m, m);
}

void HarmonicKalman::Propagate(double dt) {
  const int m = state_size();
  // F = blockdiag(1, R(w dt), R(2 w dt), ...), R(a) the rotation of the phasor (p, q) by a
  F_.setZero(m, m);
  F_(0, 0) = 1.0;
  for (int k = 1; k <= params_.harmonics; ++k) {
    const double a = k * params_.omega * dt, c = std::cos(a), s = std::sin(a);
    const int i = 2 * k - 1;
    F_(i, i) = c;
    F_(i, i + 1) = -s;
    F_(i + 1, i) = s;
    F_(i + 1, i + 1) = c;
  }
  x_ = F_ * x_;
  scratch_.noalias() = F_ * P_;
  P_.noalias() = scratch_ * F_.transpose();
  // random-walk process noise, Q = diag(q_c, q_h, ...) dt
  P_(0, 0) += params_.baseline_diffusion * dt;
  for (int i = 1; i < m; ++i) P_(i, i) += params_.harmonic_diffusion * dt;
}

void HarmonicKalman::Update(double dt, double y) {
  Propagate(dt);
  const int m = state_size();
  // H = (1, 1, 0, 1, 0, ...): y = c + sum_k p_k; ph = P H^T, s = H P H^T + R
  std::array<double, 1 + 2 * kMaxHarmonics> ph{};
  for (int r = 0; r < m; ++r) {
    double v = P_(r, 0);
    for (int k = 1; k <= params_.harmonics; ++k) v += P_(r, 2 * k - 1);
    ph[r] = v;
  }
  double s = ph[0] + params_.measurement_variance;
  double innovation = y - x_[0];
  for (int k = 1; k <= params_.harmonics; ++k) {
    s += ph[2 * k - 1];
    innovation -= x_[2 * k - 1];
  }
  // x += K innovation, P -= K (P H^T)^T with K = ph / s; symmetrized against round-off
  for (int r = 0; r < m; ++r) x_[r] += ph[r] / s * innovation;
  for (int c = 0; c < m; ++c) {
    for (int r = 0; r < m; ++r) P_(r, c) -= ph[r] * ph[c] / s;
  }
  for (int c = 0; c < m; ++c) {
    for (int r = c + 1; r < m; ++r) P_(r, c) = P_(c, r) = 0.5 * (P_(r, c) + P_(c, r));
  }
}

double HarmonicKalman::Predict(double h) const {
  double y = x_[0];
  for (int k = 1; k <= params_.harmonics; ++k) {
    const double a = k * params_.omega * h;
    y += x_[2 * k - 1] * std::cos(a) - x_[2 * k] * std::sin(a);
  }
  return y;
}

double EstimatePeriod(const double* t, const double* y, int n, double min_period,
                      double max_period) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (n < 8 || !(t[n - 1] > t[0])) return nan;
  const double dt = (t[n - 1] - t[0]) / (n - 1);
  // Pearson correlation of y[0, n-lag) with y[lag, n): each segment centred on its own mean,
  // so a trend or a partial cycle in the overlap does not bias the peak
  double mean = 0.0;  // removed first against cancellation in the sums
  for (int i = 0; i < n; ++i) mean += y[i];
  mean /= n;
  auto autocorrelation = [&](int lag) {
    const int m = n - lag;
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    for (int i = 0; i < m; ++i) {
      const double a = y[i] - mean, b = y[i + lag] - mean;
      sa += a;
      sb += b;
      saa += a * a;
      sbb += b * b;
      sab += a * b;
    }
    const double cov = sab - sa * sb / m, va = saa - sa * sa / m, vb = sbb - sb * sb / m;
    return va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0.0;
  };
  const int lag_min = std::max(2, static_cast<int>(std::floor(min_period / dt)));
  const int lag_max = std::min(static_cast<int>(std::ceil(max_period / dt)), 2 * n / 3);
  if (lag_max - lag_min < 2) return nan;
  constexpr double kMinPeak = 0.3;        // correlation a period peak must reach
  constexpr double kMinProminence = 0.3;  // and its rise above the lowest correlation before it
  // the correlation first drops (a periodic signal decorrelates at half a period), then peaks
  double lowest = 1.0;
  for (int lag = 1; lag < lag_min; ++lag) lowest = std::min(lowest, autocorrelation(lag));
  double prev = autocorrelation(lag_min - 1), cur = autocorrelation(lag_min);
  int best_lag = -1;
  double best_r = kMinPeak, best_prev = 0, best_next = 0;
  for (int lag = lag_min; lag < lag_max; ++lag) {
    const double next = autocorrelation(lag + 1);
    lowest = std::min(lowest, cur);
    if (cur >= prev && cur > next && cur > best_r && cur - lowest >= kMinProminence) {
      // the first peak within 10 % of the best so far wins: multiples of the period come later
      if (best_lag < 0 || cur > best_r * 1.1) {
        best_lag = lag;
        best_r = cur;
        best_prev = prev;
        best_next = next;
      }
    }
    prev = cur;
    cur = next;
  }
  if (best_lag < 0) return nan;
  const double curvature = best_prev - 2 * best_r + best_next;
  const double shift = curvature < 0 ? 0.5 * (best_prev - best_next) / curvature : 0.0;
  return (best_lag + std::clamp(shift, -0.5, 0.5)) * dt;
}

double EstimateNoiseVariance(const double* y, int n) {
  NSIM_CHECK(n >= 5, "noise estimate needs >= 5 samples, got ", n);
  // fourth difference (1, -4, 6, -4, 1): white noise of variance s^2 gives 70 s^2, a smooth
  // signal only its fourth derivative times dt^4
  double sum = 0.0;
  for (int i = 2; i + 2 < n; ++i) {
    const double d4 = y[i - 2] - 4 * y[i - 1] + 6 * y[i] - 4 * y[i + 1] + y[i + 2];
    sum += d4 * d4;
  }
  return sum / (70.0 * (n - 4));
}

}  // namespace nsim
