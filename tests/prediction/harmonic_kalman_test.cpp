#include "common/prediction/harmonic_kalman.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace nsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Lujan-type cycle with n = 2: sin^4(pi t / tau) has harmonics 1 and 2 of w = 2 pi / tau
double Breath(double t, double tau, double amplitude) {
  return amplitude * std::pow(std::sin(kPi * t / tau), 4);
}

TEST(EstimatePeriod, FindsThePeriodOfSinusoidsAndBreathingCurves) {
  const double dt = 1.0 / 30;
  for (double tau : {2.5, 3.7, 5.1}) {
    std::vector<double> t(300), sine(300), breath(300);
    for (int i = 0; i < 300; ++i) {
      t[i] = 7.0 + i * dt;
      sine[i] = std::sin(2 * kPi * t[i] / tau + 0.3);
      breath[i] = Breath(t[i], tau, 0.012);
    }
    // the parabolic refinement resolves a fraction of the sampling step
    EXPECT_NEAR(EstimatePeriod(t.data(), sine.data(), 300, 1.5, 8.0), tau, 0.5 * dt) << tau;
    EXPECT_NEAR(EstimatePeriod(t.data(), breath.data(), 300, 1.5, 8.0), tau, 0.5 * dt) << tau;
  }
  // no periodicity: NaN
  std::vector<double> t(300), line(300);
  for (int i = 0; i < 300; ++i) {
    t[i] = i * dt;
    line[i] = 0.001 * i;
  }
  EXPECT_TRUE(std::isnan(EstimatePeriod(t.data(), line.data(), 300, 1.5, 8.0)));
}

TEST(EstimateNoiseVariance, RecoversWhiteNoiseOnASmoothSignal) {
  const int n = 20000;
  const double sigma = 2e-5;  // m
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<double> y(n);
  for (int i = 0; i < n; ++i) y[i] = Breath(i / 30.0, 4.0, 0.012) + noise(rng);
  // the fourth-difference estimator averages correlated terms: ~5 % statistical spread at this n
  EXPECT_NEAR(EstimateNoiseVariance(y.data(), n), sigma * sigma, 0.1 * sigma * sigma);
}

TEST(HarmonicKalman, PredictsATwoHarmonicSignalAfterConvergence) {
  const double tau = 4.0, w = 2 * kPi / tau, dt = 1.0 / 30, amplitude = 0.012;
  HarmonicKalmanParams params;
  params.harmonics = 2;
  params.omega = w;
  params.measurement_variance = 1e-12;
  params.harmonic_diffusion = 1e-9;
  params.baseline_diffusion = 1e-10;
  HarmonicKalman filter;
  filter.Reset(params, Breath(0, tau, amplitude), 1e-4);
  double t = 0;
  for (int k = 1; k < 640; ++k) {  // ends on an inhale flank, where the signal moves
    t = k * dt;
    filter.Update(dt, Breath(t, tau, amplitude));
  }
  double max_error = 0, max_naive = 0;
  for (double h : {0.1, 0.3, 0.6}) {
    max_error = std::max(max_error, std::abs(filter.Predict(h) - Breath(t + h, tau, amplitude)));
    max_naive =
        std::max(max_naive, std::abs(Breath(t, tau, amplitude) - Breath(t + h, tau, amplitude)));
  }
  // the model is exact for sin^4: the error is a small fraction of the amplitude
  EXPECT_LT(max_error, 0.01 * amplitude);
  EXPECT_GT(max_naive, 0.05 * amplitude);  // the test signal moves over these horizons
}

}  // namespace
}  // namespace nsim
