#include "common/robot/rate_limit.h"

#include <gtest/gtest.h>

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;

TEST(RateLimit, BrakingSpeedByHand) {
  const double a = 2.0, dt = 0.01;  // a dt = 0.02 m/s, a dt^2 = 2e-4 m
  for (int n = 0; n < 50; ++n) {
    const double distance = a * dt * dt * n * (n + 1) / 2.0;
    EXPECT_NEAR(CalcBrakingSpeed(distance, a, dt), n * a * dt, 1e-12) << n;
  }
  // below one step of braking: land in one step
  EXPECT_NEAR(CalcBrakingSpeed(1e-4, a, dt), 1e-4 / dt, 1e-15);
  // x = 2 (between 1 and 3): n = 1, c = 1/2 -> profile 1.5, 0.5, 0 sums to 2
  EXPECT_NEAR(CalcBrakingSpeed(4e-4, a, dt), 1.5 * a * dt, 1e-15);
}

TEST(RateLimit, BrakingSpeedIsConsistentFromStepToStep) {
  const double a = 3.0, dt = 0.007;
  for (double d = 1e-6; d < 0.5; d *= 1.37) {
    const double v = CalcBrakingSpeed(d, a, dt);
    if (v < a * dt) {
      EXPECT_NEAR(v * dt, d, 1e-15);  // lands
    } else {
      EXPECT_NEAR(CalcBrakingSpeed(d - v * dt, a, dt), v - a * dt, 1e-12) << d;
    }
  }
}

TEST(RateLimit, StopsOnTheTargetWithoutOvershootFromRest) {
  const double v_max = 0.3, a_max = 2.0, dt = 0.004;
  for (double target : {1e-6, 0.01, 0.5, 2.0}) {
    Eigen::Matrix<double, 1, 1> x(0.0), v(0.0);
    double max_x = 0.0;
    for (int step = 0; step < 100000; ++step) {
      const Eigen::Matrix<double, 1, 1> old_v = v;
      StepVelocityTowards<1>(Eigen::Matrix<double, 1, 1>(target - x[0]), v_max, a_max, dt, &v);
      EXPECT_LE(std::abs(v[0]), v_max + kRoundoff);
      EXPECT_LE(std::abs(v[0] - old_v[0]), a_max * dt * (1 + kRoundoff));
      x += v * dt;
      max_x = std::max(max_x, x[0]);
      if (std::abs(target - x[0]) < kRoundoff && std::abs(v[0]) < kRoundoff) break;
    }
    EXPECT_NEAR(x[0], target, kRoundoff);
    EXPECT_LE(max_x, target * (1 + 1e-12)) << "overshoot for target " << target;
  }
}

TEST(RateLimit, BrakeToRest) {
  Eigen::Vector3d v(0.3, 0.4, 0.0);  // speed 0.5
  StepVelocityToRest<3>(10.0, 0.01, &v);
  EXPECT_NEAR(v.norm(), 0.4, kRoundoff);
  EXPECT_NEAR(v.x() / v.y(), 0.75, kRoundoff);  // direction kept
  for (int i = 0; i < 3; ++i) StepVelocityToRest<3>(10.0, 0.01, &v);
  EXPECT_NEAR(v.norm(), 0.1, kRoundoff);
  // the last step (up to rounding, one more) reaches exactly zero
  for (int i = 0; i < 2; ++i) StepVelocityToRest<3>(10.0, 0.01, &v);
  EXPECT_EQ(v.norm(), 0.0);
}

}  // namespace
}  // namespace nsim
