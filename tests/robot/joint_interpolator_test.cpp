#include "common/robot/joint_interpolator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;  // relative slack on a limit
constexpr double kReached = 1e-12;   // rad
constexpr double kDt = 0.005;        // s
// rounding of q (eps * 3 rad) over dt^2, where a joint is stopped on its position limit
constexpr double kAccelRoundoff = 1e-10;  // rad/s^2

TEST(JointInterpolator, ReachesTheCommandWithinEveryLimit) {
  const Iiwa14Model model;
  const Iiwa14Config& c = model.config();
  const JointInterpolator interp(model);
  JointState s = interp.MakeState(Vector7d::Zero());
  const Vector7d cmd = (Vector7d() << 1.0, -0.5, 2.0, 1.2, -2.5, 0.3, -3.0).finished();
  int steps = 0;
  for (; steps < 100000; ++steps) {
    const JointState old = s;
    const JointStepReport r = interp.Step(cmd, kDt, &s);
    ASSERT_TRUE(r.accepted);
    for (int i = 0; i < 7; ++i) {
      ASSERT_LE(std::abs(s.qd[i]), c.velocity_limit[i] * (1 + kRoundoff));
      ASSERT_LE(std::abs(s.qd[i] - old.qd[i]) / kDt, c.acceleration_limit[i] * (1 + kRoundoff));
    }
    if (!r.rate_limited && s.qd.isZero()) break;
  }
  EXPECT_LT((s.q - cmd).cwiseAbs().maxCoeff(), kReached);
  // joint 7 moves 3 rad at <= 2.356 rad/s: at least 1.27 s
  EXPECT_GE(steps * kDt, 3.0 / c.velocity_limit[6]);
}

TEST(JointInterpolator, ClampsToPositionLimitsUnderRandomCommands) {
  const Iiwa14Model model;
  const Iiwa14Config& c = model.config();
  const JointInterpolator interp(model);
  JointState s = interp.MakeState(Vector7d::Zero());
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-4.0, 4.0);
  Vector7d cmd = Vector7d::Zero();
  int clamped = 0;
  for (int i = 0; i < 20000; ++i) {
    if (i % 50 == 0) {
      for (int j = 0; j < 7; ++j) cmd[j] = u(rng);
    }
    const JointState old = s;
    const JointStepReport r = interp.Step(cmd, kDt, &s);
    clamped += r.clamped_to_limits;
    ASSERT_TRUE(model.IsWithinLimits(s.q));
    for (int j = 0; j < 7; ++j) {
      ASSERT_LE(std::abs(s.qd[j]), c.velocity_limit[j] * (1 + kRoundoff));
      ASSERT_LE(std::abs(s.qd[j] - old.qd[j]) / kDt, c.acceleration_limit[j] + kAccelRoundoff)
          << " joint " << j << " step " << i;
    }
  }
  EXPECT_GT(clamped, 0);  // commands up to 4 rad exceed every limit sometimes
}

TEST(JointInterpolator, RejectsNaNAndBrakes) {
  const Iiwa14Model model;
  const JointInterpolator interp(model);
  JointState s = interp.MakeState(Vector7d::Zero());
  for (int i = 0; i < 100; ++i) interp.Step(Vector7d::Constant(1.0), kDt, &s);
  ASSERT_GT(s.qd.norm(), 0.0);
  Vector7d bad = Vector7d::Constant(1.0);
  bad[3] = std::nan("");
  const JointStepReport r = interp.Step(bad, kDt, &s);
  EXPECT_FALSE(r.accepted);
  EXPECT_TRUE(s.q.allFinite());
  for (int i = 0; i < 1000; ++i) interp.Step(bad, kDt, &s);
  EXPECT_TRUE(s.qd.isZero());
  EXPECT_THROW(interp.Step(Vector7d::Zero(), -kDt, &s), InputError);
  EXPECT_THROW(interp.MakeState(Vector7d::Constant(3.5)), InputError);
}

}  // namespace
}  // namespace nsim
