#include "common/prediction/horizon_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

TEST(HorizonEstimator, ConstantRateLoopIsPredictedExactly) {
  HorizonConfig config;
  config.localization_delay = 0.05;
  HorizonEstimator estimator(config);
  EXPECT_TRUE(std::isnan(estimator.PredictNextLoopTime()));
  EXPECT_DOUBLE_EQ(estimator.CalcHorizon(0.0), 0.05);
  const double t0 = 1000.0, dt = 0.037;  // s
  for (int k = 0; k < 25; ++k) estimator.AddLoopTime(t0 + k * dt);
  const double tol = 1e-9;  // s: round-off of times near 1000 s
  EXPECT_NEAR(estimator.PredictNextLoopTime(), t0 + 25 * dt, tol);
  // eq. 4.10 relative to a marker sample taken at the last loop start
  EXPECT_NEAR(estimator.CalcHorizon(t0 + 24 * dt), dt + 0.05, tol);
}

TEST(HorizonEstimator, FewSamplesUseWhatIsThere) {
  HorizonEstimator estimator{HorizonConfig{}};
  estimator.AddLoopTime(2.0);
  EXPECT_DOUBLE_EQ(estimator.PredictNextLoopTime(), 2.0);
  estimator.AddLoopTime(2.1);
  EXPECT_NEAR(estimator.PredictNextLoopTime(), 2.2, 1e-12);
}

TEST(HorizonEstimator, ASlowlyGrowingJitteryStepIsPredictedWithinTheJitter) {
  // the loop slows down slowly (thesis fig. 4.3) and jitters. Baseline of eq. 4.20: no
  // prediction, i.e. the next loop at the last loop time (error = one whole step)
  HorizonConfig config;
  config.window = 20;
  HorizonEstimator estimator(config);
  const double sigma = 0.004;  // step jitter (s)
  std::mt19937_64 rng(3);
  std::normal_distribution<double> jitter(0.0, sigma);
  double t = 0, filter_sq = 0, none_sq = 0;
  int count = 0;
  for (int k = 0; k < 400; ++k) {
    const double step = 0.033 + 1e-5 * k + jitter(rng);
    if (k > 30) {
      filter_sq += std::pow(estimator.PredictNextLoopTime() - (t + step), 2);
      none_sq += step * step;
      ++count;
    }
    t += step;
    estimator.AddLoopTime(t);
  }
  const double rms_filter = std::sqrt(filter_sq / count), rms_none = std::sqrt(none_sq / count);
  EXPECT_LT(rms_filter, 0.3 * rms_none);
  // the jitter itself is unpredictable; the timestamps integrate it, so the line fit through the
  // last WF of them is off by a few sigma at most
  EXPECT_LT(rms_filter, 3 * sigma);
}

TEST(HorizonEstimator, WindowSearchPicksALongWindowForJitteryTimestamps) {
  HorizonConfig config;
  config.optimize_window = true;
  config.window_max = 30;
  config.history = 120;
  HorizonEstimator estimator(config);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> jitter(0.0, 0.005);
  double t = 0;
  for (int k = 0; k < 120; ++k) {
    t += 0.033;
    estimator.AddLoopTime(t + jitter(rng));
  }
  EXPECT_GE(estimator.window(), 15);
  EXPECT_LE(estimator.window(), 29);
}

TEST(HorizonEstimator, BadInputThrowsInputError) {
  HorizonConfig config;
  config.window = 1;
  try {
    HorizonEstimator{config};
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "horizon.window must be >= 2, got 1");
  }
  config = HorizonConfig();
  config.localization_delay = -0.1;
  EXPECT_THROW(HorizonEstimator{config}, InputError);
  HorizonEstimator estimator{HorizonConfig{}};
  estimator.AddLoopTime(1.0);
  try {
    estimator.AddLoopTime(1.0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "loop time must increase: got 1 s after 1 s");
  }
  EXPECT_THROW(estimator.AddLoopTime(std::nan("")), InputError);
}

}  // namespace
}  // namespace nsim
