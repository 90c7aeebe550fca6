#include "common/breathing/breathing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// statistics of a sample
struct Stats {
  double mean = 0, std = 0;
};
Stats Describe(const std::vector<double>& v) {
  Stats s;
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  for (double x : v) s.std += (x - s.mean) * (x - s.mean);
  s.std = std::sqrt(s.std / (v.size() - 1));
  return s;
}

TEST(BreathingModel, PeakDisplacementIsSiDominantWithSmallerApAndLr) {
  const BreathingModel model{BreathingConfig{}};
  // default axes: inhalation moves inferior (-z), anterior (+y), left (+x)
  EXPECT_DOUBLE_EQ(model.peak_displacement().z(), -0.012);
  EXPECT_DOUBLE_EQ(model.peak_displacement().y(), 0.0038);
  EXPECT_DOUBLE_EQ(model.peak_displacement().x(), 0.0013);
}

// period and amplitude measured on the signal itself: one inhale peak per cycle, at its middle
TEST(BreathingModel, PeriodAndAmplitudeStatisticsMatchTheConfig) {
  BreathingConfig config;
  config.period = 4.0;
  config.period_cv = 0.1;
  config.amplitude_cv = 0.15;
  config.horizon = 4000.0;
  config.random_seed = 11;
  const BreathingModel model(config);
  const double dt = 0.01;  // sampling of the signal (s)
  std::vector<double> peak_times, peak_amplitudes;
  double prev = 0, cur = 0;
  for (double t = 0; t < config.horizon; t += dt) {
    const double next = -model.CalcDisplacement(t).z();  // SI displacement, inhalation positive
    if (cur > prev && cur >= next) {
      peak_times.push_back(t - dt);
      peak_amplitudes.push_back(cur);
    }
    prev = cur;
    cur = next;
  }
  const int n = static_cast<int>(peak_times.size());
  ASSERT_GT(n, 900);
  // exactly one peak per cycle
  EXPECT_NEAR(n, config.horizon / config.period, 4 * std::sqrt(n) * config.period_cv);
  std::vector<double> intervals;
  for (int i = 1; i < n; ++i) intervals.push_back(peak_times[i] - peak_times[i - 1]);
  const Stats period = Describe(intervals);
  const Stats amplitude = Describe(peak_amplitudes);
  // 4 standard errors of the mean, plus the sampling step for the peak times
  const double period_sd = config.period_cv * config.period;
  EXPECT_NEAR(period.mean, config.period, 4 * period_sd / std::sqrt(n) + dt);
  const double amplitude_sd = config.amplitude_cv * config.si_amplitude;
  EXPECT_NEAR(amplitude.mean, config.si_amplitude, 4 * amplitude_sd / std::sqrt(n));
  // peak amplitude std: a_k A_si, a_k truncated normal (3 sd: std factor 0.987)
  EXPECT_NEAR(amplitude.std, 0.987 * amplitude_sd, 0.1 * amplitude_sd);
  // the interval between peaks k and k+1 is (tau_k + tau_k+1) / 2: std / sqrt(2)
  EXPECT_NEAR(period.std, 0.987 * period_sd / std::sqrt(2.0), 0.1 * period_sd);
}

TEST(BreathingModel, CycleTableStatisticsMatchTheConfig) {
  BreathingConfig config;
  config.horizon = 8000.0;
  const BreathingModel model(config);
  std::vector<double> periods, factors;
  for (const auto& c : model.cycles()) {
    periods.push_back(c.period);
    factors.push_back(c.amplitude_factor);
  }
  const double n = periods.size();
  const Stats p = Describe(periods), a = Describe(factors);
  EXPECT_NEAR(p.mean, config.period, 4 * config.period_cv * config.period / std::sqrt(n));
  EXPECT_NEAR(a.mean, 1.0, 4 * config.amplitude_cv / std::sqrt(n));
  EXPECT_NEAR(p.std, 0.987 * config.period_cv * config.period,
              0.1 * config.period_cv * config.period);
  EXPECT_NEAR(a.std, 0.987 * config.amplitude_cv, 0.1 * config.amplitude_cv);
  // cycles tile the time line
  for (size_t k = 1; k < model.cycles().size(); ++k)
    EXPECT_DOUBLE_EQ(model.cycles()[k].start,
                     model.cycles()[k - 1].start + model.cycles()[k - 1].period);
  EXPECT_GE(model.cycles().back().start + model.cycles().back().period, config.horizon);
}

TEST(BreathingModel, ReproducibleWithASeedAndDifferentWithAnother) {
  BreathingConfig config;
  config.horizon = 120;
  config.random_seed = 7;
  const BreathingModel a(config), b(config);
  config.random_seed = 8;
  const BreathingModel c(config);
  double max_difference = 0;
  for (double t = 0; t <= 120; t += 0.05) {
    EXPECT_EQ(a.CalcDisplacement(t), b.CalcDisplacement(t)) << "t = " << t;
    max_difference =
        std::max(max_difference, (a.CalcDisplacement(t) - c.CalcDisplacement(t)).norm());
  }
  // another seed: different cycles, differing by a good part of the amplitude somewhere
  EXPECT_GT(max_difference, 0.25 * config.si_amplitude);
}

TEST(BreathingModel, ContinuousWithContinuousVelocityAcrossCycleBoundaries) {
  BreathingConfig config;
  config.horizon = 200;
  config.shape_exponent = 1;  // the least flat rest: the hardest case for continuity
  config.drift_velocity = Eigen::Vector3d(1e-5, 0, 2e-5);
  const BreathingModel model(config);
  const double eps = 1e-6;  // s
  // bound on the speed: amplitude factor <= 1 + 3 cv, d/dt sin^2n <= 2n pi / tau_min
  const double tau_min = config.period * (1 - 3 * config.period_cv);
  const double max_speed = (1 + 3 * config.amplitude_cv) * model.peak_displacement().norm() * 2 *
                               config.shape_exponent * kPi / tau_min +
                           config.drift_velocity.norm();
  for (size_t k = 1; k + 1 < model.cycles().size(); ++k) {
    const double tb = model.cycles()[k].start;
    EXPECT_LE((model.CalcDisplacement(tb + eps) - model.CalcDisplacement(tb - eps)).norm(),
              2 * eps * max_speed);
    // velocity at the boundary is the drift alone, from both sides
    EXPECT_LE((model.CalcVelocity(tb + eps) - model.CalcVelocity(tb - eps)).norm(),
              1e-3 * max_speed);
    // exhale rest at each cycle start
    EXPECT_NEAR(model.CalcShape(tb), 0.0, 1e-12);
  }
}

TEST(BreathingModel, VelocityMatchesCentralDifferences) {
  BreathingConfig config;
  config.horizon = 30;
  config.drift_velocity = Eigen::Vector3d(0, 1e-4, 0);
  const BreathingModel model(config);
  const double h = 1e-5;  // s
  for (double t = 0.3; t < 29; t += 0.37) {
    const Eigen::Vector3d fd =
        (model.CalcDisplacement(t + h) - model.CalcDisplacement(t - h)) / (2 * h);
    // central-difference truncation ~ h^2 |d'''|, round-off ~ eps |d| / h
    EXPECT_LE((fd - model.CalcVelocity(t)).norm(), 1e-6 * model.peak_displacement().norm()) << t;
  }
}

TEST(BreathingModel, DriftWithoutBreathingIsLinear) {
  BreathingConfig config;
  config.si_amplitude = config.ap_amplitude = config.lr_amplitude = 0;
  config.drift_velocity = Eigen::Vector3d(1e-4, -2e-4, 3e-4);
  config.horizon = 10;
  const BreathingModel model(config);
  for (double t : {0.0, 1.5, 9.9})
    EXPECT_LE((model.CalcDisplacement(t) - config.drift_velocity * t).norm(), 1e-15);
}

TEST(BreathingModel, StartPhaseShiftsTheFirstCycle) {
  BreathingConfig config;
  config.start_phase = 0.5;  // t = 0 at full inhale
  config.amplitude_cv = 0;
  config.horizon = 20;
  const BreathingModel model(config);
  EXPECT_NEAR(model.CalcShape(0.0), 1.0, 1e-12);
  EXPECT_LT(model.t_begin(), 0.0);
}

TEST(BreathingConfig, BadValuesNameTheField) {
  auto message = [](BreathingConfig c) -> std::string {
    try {
      c.Validate();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  BreathingConfig c;
  c.period = -1;
  EXPECT_EQ(message(c), "breathing.period must be > 0 (s), got -1");
  c = BreathingConfig();
  c.shape_exponent = 0;
  EXPECT_EQ(message(c), "breathing.shape_exponent must be in [1, 6], got 0");
  c = BreathingConfig();
  c.amplitude_cv = 0.5;
  EXPECT_EQ(message(c), "breathing.amplitude_cv must be in [0, 0.3], got 0.5");
  c = BreathingConfig();
  c.si_amplitude = std::nan("");
  EXPECT_EQ(message(c), "breathing.si_amplitude must be >= 0 (m), got nan");
  c = BreathingConfig();
  c.axis_ap = Eigen::Vector3d::Zero();
  EXPECT_EQ(message(c).rfind("breathing.axis_ap must be a finite non-zero vector", 0), 0u);
  c = BreathingConfig();
  c.period = 0;
  EXPECT_THROW(BreathingModel{c}, InputError);
}

}  // namespace
}  // namespace nsim
