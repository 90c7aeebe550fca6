// The motion forecast against the robots it forecasts: a CartesianRobot and a JointInterpolator
// driven by jumping commands under their limits, observed only through their poses and joint
// angles (as the controller sees them in the frames); the forecast from any step over the
// commands that follow must land where the robot actually went, and it must differ from the
// last command (the robot lags behind a jump), else the test would not tell the two apart.
#include "common/robot/motion_forecast.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

constexpr double kDt = 0.02;  // s: the patient's step

Eigen::Isometry3d Pose(const Eigen::Vector3d& p, const Eigen::Vector3d& rotation_vector) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = ExpSO3(rotation_vector);
  X.translation() = p;
  return X;
}

TEST(MotionForecast, CartesianForecastLandsWhereTheRobotWent) {
  MotionForecastConfig config;  // 0.05 m/s, 0.5 rad/s, 0.5 m/s^2, 5 rad/s^2
  const CartesianRobot robot(config.cartesian);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jump(-2e-3, 2e-3);  // up to 2 mm, 0.02 rad a command
  std::vector<Eigen::Isometry3d> commands, poses;
  CartesianRobotState state = robot.MakeState(Pose({0.1, 0.2, 0.05}, {0.1, -0.2, 0.3}));
  Eigen::Isometry3d command = state.X_WE;
  for (int k = 0; k < 120; ++k) {
    poses.push_back(state.X_WE);
    command = Pose(command.translation() + Eigen::Vector3d(jump(rng), jump(rng), jump(rng)),
                   LogSO3(command.linear()) + 10.0 * Eigen::Vector3d(jump(rng), jump(rng), jump(rng)));
    commands.push_back(command);
    robot.Step(command, kDt, &state);
  }
  poses.push_back(state.X_WE);
  const int d = 3;  // commands in flight
  double largest_lag = 0.0;
  MotionForecast forecast(config);
  for (int k = 0; k + d < static_cast<int>(commands.size()); ++k) {
    forecast.Observe(k * kDt, poses[k], {});
    if (k == 0) continue;  // the velocity needs two states
    ASSERT_TRUE(forecast.has_velocity());
    const std::vector<Eigen::Isometry3d> flight(commands.begin() + k, commands.begin() + k + d);
    const Eigen::Isometry3d X = forecast.ForecastPose(flight, kDt);
    const Eigen::Isometry3d& actual = poses[k + d];
    EXPECT_LT((X.translation() - actual.translation()).norm(), 1e-12) << k;
    EXPECT_LT(LogSO3(X.linear() * actual.linear().transpose()).norm(), 1e-10) << k;
    largest_lag = std::max(largest_lag, (flight.back().translation() - actual.translation()).norm());
  }
  EXPECT_GT(largest_lag, 1e-3) << "the robot kept up with every command: nothing to forecast";
}

TEST(MotionForecast, JointForecastLandsWhereTheIiwaWent) {
  MotionForecastConfig config;
  const Iiwa14Model model(config.iiwa);
  const JointInterpolator joints(model);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> jump(-0.03, 0.03);  // rad a command
  const Vector7d q0 = (Vector7d() << 0.3, 0.6, -0.2, -1.2, 0.1, 0.9, 0.4).finished();
  JointState state = joints.MakeState(q0);
  Vector7d command = q0;
  std::vector<Vector7d> commands, angles;
  for (int k = 0; k < 120; ++k) {
    angles.push_back(state.q);
    for (int i = 0; i < 7; ++i) command[i] += jump(rng);
    commands.push_back(command);
    joints.Step(command, kDt, &state);
  }
  angles.push_back(state.q);
  const int d = 5;
  double largest_lag = 0.0;
  MotionForecast forecast(config);
  for (int k = 0; k + d < static_cast<int>(commands.size()); ++k) {
    forecast.Observe(1.0 + k * kDt, Eigen::Isometry3d::Identity(),
                     std::vector<double>(angles[k].data(), angles[k].data() + 7));
    if (k == 0) continue;
    const std::vector<Vector7d> flight(commands.begin() + k, commands.begin() + k + d);
    const Vector7d q = forecast.ForecastJoints(flight, kDt);
    EXPECT_LT((q - angles[k + d]).cwiseAbs().maxCoeff(), 1e-12) << k;
    largest_lag = std::max(largest_lag, (flight.back() - angles[k + d]).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(largest_lag, 0.01) << "the iiwa kept up with every command: nothing to forecast";
}

// without a velocity (one state, or a state that does not follow in time) the robot starts at
// rest: from rest one step covers at most a_max dt^2
TEST(MotionForecast, StartsAtRestWithoutAVelocity) {
  MotionForecastConfig config;
  MotionForecast forecast(config);
  const Eigen::Isometry3d X0 = Pose({0.1, 0.2, 0.3}, {0.0, 0.0, 0.0});
  forecast.Observe(2.0, X0, {});
  EXPECT_FALSE(forecast.has_velocity());
  const Eigen::Isometry3d far = Pose({0.2, 0.2, 0.3}, {0.0, 0.0, 0.0});
  const double step = config.cartesian.max_linear_acceleration * kDt * kDt;
  EXPECT_NEAR((forecast.ForecastPose({far}, kDt).translation() - X0.translation()).norm(), step,
              1e-15);
  forecast.Observe(2.02, Pose({0.101, 0.2, 0.3}, {0.0, 0.0, 0.0}), {});
  EXPECT_TRUE(forecast.has_velocity());
  forecast.Observe(1.0, X0, {});  // back in time: starts over
  EXPECT_FALSE(forecast.has_velocity());
  EXPECT_NEAR((forecast.ForecastPose({far}, kDt).translation() - X0.translation()).norm(), step,
              1e-15);
  // no commands in flight: the robot coasts at its measured velocity (here none)
  EXPECT_TRUE(forecast.ForecastPose({}, kDt).isApprox(X0, 0.0));
}

TEST(MotionForecast, RefusesWhatItCannotForecastFrom) {
  MotionForecastConfig config;
  MotionForecast forecast(config);
  EXPECT_THROW(forecast.ForecastPose({}, kDt), InputError);  // no state yet
  forecast.Observe(0.0, Eigen::Isometry3d::Identity(), {});
  EXPECT_THROW(forecast.ForecastJoints({}, kDt), InputError);  // no joints measured
  EXPECT_THROW(forecast.ForecastPose({}, 0.0), InputError);
  EXPECT_THROW(forecast.ForecastPose({}, std::nan("")), InputError);
  EXPECT_THROW(forecast.Observe(0.1, Eigen::Isometry3d::Identity(), {0.1, 0.2}), InputError);
  std::vector<double> q(7, 0.1);
  q[3] = std::nan("");
  EXPECT_THROW(forecast.Observe(0.1, Eigen::Isometry3d::Identity(), q), InputError);
  Eigen::Isometry3d sheared = Eigen::Isometry3d::Identity();
  sheared.linear()(0, 1) = 0.5;
  EXPECT_THROW(forecast.Observe(0.1, sheared, {}), InputError);
  try {
    forecast.Observe(0.1, Eigen::Isometry3d::Identity(), {0.1});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 7 joint angles, got 1"), std::string::npos)
        << e.what();
  }
  config.cartesian.max_linear_acceleration = -1.0;
  EXPECT_THROW(MotionForecast{config}, InputError);
}

}  // namespace
}  // namespace nsim
