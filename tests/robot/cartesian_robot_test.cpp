#include "common/robot/cartesian_robot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;  // relative slack on a limit
constexpr double kReached = 1e-12;   // pose error that counts as on target (m or rad)
constexpr double kDt = 0.01;         // s
constexpr double kAtRest = 1e-9;     // speed that counts as stopped (m/s, rad/s)

CartesianRobotConfig MakeConfig() {
  CartesianRobotConfig c;
  c.max_linear_speed = 0.05;
  c.max_angular_speed = 0.5;
  c.max_linear_acceleration = 0.4;
  c.max_angular_acceleration = 3.0;
  c.workspace_min_W = Eigen::Vector3d(-0.3, -0.3, 0.0);
  c.workspace_max_W = Eigen::Vector3d(0.3, 0.3, 0.6);
  return c;
}

Eigen::Isometry3d MakePose(const Eigen::Vector3d& p, const Eigen::Vector3d& w) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = ExpSO3(w);
  X.translation() = p;
  return X;
}

// runs the robot toward a command and checks every limit at every step
struct Trace {
  int steps = 0;
  bool reached = false;
  double max_speed = 0, max_angular_speed = 0, max_accel = 0, max_angular_accel = 0;
  double max_jump = 0;  // max |p' - p| per step (m)
};

Trace RunToCommand(const CartesianRobot& robot, const Eigen::Isometry3d& cmd,
                   CartesianRobotState* s, int max_steps) {
  Trace t;
  for (; t.steps < max_steps; ++t.steps) {
    const CartesianRobotState old = *s;
    const CartesianStepReport r = robot.Step(cmd, kDt, s);
    EXPECT_TRUE(r.accepted);
    EXPECT_TRUE(robot.IsInWorkspace(s->X_WE.translation()));
    t.max_speed = std::max(t.max_speed, s->v_WE.norm());
    t.max_angular_speed = std::max(t.max_angular_speed, s->w_WE.norm());
    t.max_accel = std::max(t.max_accel, (s->v_WE - old.v_WE).norm() / kDt);
    t.max_angular_accel = std::max(t.max_angular_accel, (s->w_WE - old.w_WE).norm() / kDt);
    t.max_jump = std::max(t.max_jump, (s->X_WE.translation() - old.X_WE.translation()).norm());
    if (!r.rate_limited && s->v_WE.norm() < kAtRest && s->w_WE.norm() < kAtRest) {
      t.reached = true;
      break;
    }
  }
  return t;
}

TEST(CartesianRobot, ReachesTargetWithinLimits) {
  const CartesianRobotConfig c = MakeConfig();
  const CartesianRobot robot(c);
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  const Eigen::Isometry3d cmd = MakePose({0.2, -0.1, 0.4}, {0.4, -1.0, 0.7});
  const Trace t = RunToCommand(robot, cmd, &s, 100000);
  EXPECT_TRUE(t.reached);
  EXPECT_LE(t.max_speed, c.max_linear_speed * (1 + kRoundoff));
  EXPECT_LE(t.max_angular_speed, c.max_angular_speed * (1 + kRoundoff));
  EXPECT_LE(t.max_accel, c.max_linear_acceleration * (1 + kRoundoff));
  EXPECT_LE(t.max_angular_accel, c.max_angular_acceleration * (1 + kRoundoff));
  EXPECT_LE(t.max_jump, c.max_linear_speed * kDt * (1 + kRoundoff));
  EXPECT_LT((s.X_WE.translation() - cmd.translation()).norm(), kReached);
  EXPECT_LT(CalcRotationAngle(s.X_WE.linear(), cmd.linear()), kReached);
  // the speed limit is the binding one over this distance: the time is at least |d| / v_max
  const double distance = (cmd.translation() - Eigen::Vector3d(0, 0, 0.3)).norm();
  EXPECT_GE(t.steps * kDt, distance / c.max_linear_speed);
}

TEST(CartesianRobot, RotationFollowsTheGeodesic) {
  const CartesianRobot robot(MakeConfig());
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -1).normalized();
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  const Eigen::Isometry3d cmd = MakePose({0, 0, 0.3}, axis * 2.5);
  for (int i = 0; i < 2000; ++i) {
    robot.Step(cmd, kDt, &s);
    // the rotation stays about the commanded axis
    const Eigen::Vector3d w = LogSO3(s.X_WE.linear());
    if (w.norm() > 1e-9) {
      EXPECT_GT(w.normalized().dot(axis), 1.0 - 1e-9);
    }
  }
  EXPECT_LT(CalcRotationAngle(s.X_WE.linear(), cmd.linear()), kReached);
}

TEST(CartesianRobot, LimitsHoldWhenTheTargetJumpsAround) {
  const CartesianRobotConfig c = MakeConfig();
  const CartesianRobot robot(c);
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  Eigen::Isometry3d cmd = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 20000; ++i) {
    if (i % 37 == 0)
      cmd = MakePose({u(rng), u(rng), 0.3 + u(rng)}, {3 * u(rng), 3 * u(rng), 3 * u(rng)});
    const CartesianRobotState old = s;
    robot.Step(cmd, kDt, &s);
    ASSERT_TRUE(robot.IsInWorkspace(s.X_WE.translation()));
    ASSERT_LE(s.v_WE.norm(), c.max_linear_speed * (1 + kRoundoff));
    ASSERT_LE(s.w_WE.norm(), c.max_angular_speed * (1 + kRoundoff));
    ASSERT_LE((s.v_WE - old.v_WE).norm() / kDt, c.max_linear_acceleration * (1 + kRoundoff));
    ASSERT_LE((s.w_WE - old.w_WE).norm() / kDt, c.max_angular_acceleration * (1 + kRoundoff));
    ASSERT_TRUE(IsRigidTransform(s.X_WE, 1e-12));
  }
}

TEST(CartesianRobot, ClampsTheCommandToTheWorkspace) {
  const CartesianRobotConfig c = MakeConfig();
  const CartesianRobot robot(c);
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  const Eigen::Isometry3d cmd = MakePose({1.0, -0.1, 0.9}, {0, 0, 0});
  CartesianStepReport r = robot.Step(cmd, kDt, &s);
  EXPECT_TRUE(r.accepted);
  EXPECT_TRUE(r.clamped_to_workspace);
  RunToCommand(robot, cmd, &s, 100000);
  EXPECT_LT((s.X_WE.translation() - Eigen::Vector3d(0.3, -0.1, 0.6)).norm(), kReached);
  r = robot.Step(MakePose({0.1, 0.1, 0.1}, {0, 0, 0}), kDt, &s);
  EXPECT_FALSE(r.clamped_to_workspace);
}

TEST(CartesianRobot, RejectsNaNAndBrakes) {
  const CartesianRobotConfig c = MakeConfig();
  const CartesianRobot robot(c);
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  const Eigen::Isometry3d cmd = MakePose({0.3, 0, 0.3}, {0, 0, 0});
  for (int i = 0; i < 200; ++i) robot.Step(cmd, kDt, &s);
  ASSERT_NEAR(s.v_WE.norm(), c.max_linear_speed, kRoundoff);
  Eigen::Isometry3d bad = cmd;
  bad.translation().y() = std::nan("");
  const CartesianRobotState before = s;
  const CartesianStepReport r = robot.Step(bad, kDt, &s);
  EXPECT_FALSE(r.accepted);
  EXPECT_TRUE(s.X_WE.matrix().allFinite());
  // decelerates at the limit, without a jump in velocity
  EXPECT_NEAR(before.v_WE.norm() - s.v_WE.norm(), c.max_linear_acceleration * kDt, kRoundoff);
  for (int i = 0; i < 100; ++i) robot.Step(bad, kDt, &s);
  EXPECT_LT(s.v_WE.norm(), kAtRest);
  // a non-rigid command is rejected too
  Eigen::Isometry3d skewed = cmd;
  skewed.linear()(0, 1) = 0.5;
  EXPECT_FALSE(robot.Step(skewed, kDt, &s).accepted);
}

TEST(CartesianRobot, BadInputMessages) {
  CartesianRobotConfig c;
  c.max_linear_speed = -1;
  try {
    c.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "robot.max_linear_speed must be > 0 (m/s), got -1");
  }
  c = CartesianRobotConfig();
  c.workspace_max_W.z() = c.workspace_min_W.z();
  EXPECT_THROW(c.Validate(), InputError);
  c = CartesianRobotConfig();
  c.max_angular_acceleration = std::nan("");
  EXPECT_THROW(CartesianRobot{c}, InputError);
  const CartesianRobot robot(MakeConfig());
  EXPECT_THROW(robot.MakeState(MakePose({2, 0, 0}, {0, 0, 0})), InputError);
  CartesianRobotState s = robot.MakeState(MakePose({0, 0, 0.3}, {0, 0, 0}));
  EXPECT_THROW(robot.Step(s.X_WE, 0.0, &s), InputError);
  EXPECT_THROW(robot.Step(s.X_WE, std::nan(""), &s), InputError);
}

}  // namespace
}  // namespace nsim
