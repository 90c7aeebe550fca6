#include "common/scene/robot_driver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/core/error.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

constexpr double kTol = 1e-12;

TEST(RobotDriverTest, PlanPutsTheTipOnThePathWithTheNeedleAlongIt) {
  NeedleConfig needle;
  needle.p_FBase = Eigen::Vector3d(0.01, 0, 0.02);  // a tool offset
  const RigidNeedleModel model(needle);
  const Eigen::Vector3d entry(0.04, 0.067, 0.005), target(0.03, 0.015, -0.01);
  const InsertionPlan plan = MakeInsertionPlan(entry, target, model, 0.01);
  for (double s : {0.0, 0.01, plan.total_travel()}) {
    const Eigen::Isometry3d X_WN = model.CalcNeedlePose(plan.CalcFlangePose(s));
    const Eigen::Vector3d tip = CalcTipPosition(X_WN, model.length());
    EXPECT_TRUE(tip.isApprox(plan.start_tip() + s * plan.direction, kTol));
    EXPECT_TRUE(X_WN.linear().col(2).isApprox(plan.direction, kTol));
  }
  EXPECT_TRUE(CalcTipPosition(model.CalcNeedlePose(plan.CalcFlangePose(plan.total_travel())),
                              model.length())
                  .isApprox(target, 1e-12));
}

TEST(RobotDriverTest, CartesianRobotFollowsUnderItsSpeedLimit) {
  RobotDriverConfig config;
  config.cartesian.max_linear_speed = 0.05;
  RobotDriver robot(config, Eigen::Isometry3d::Identity());
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = Eigen::Vector3d(0.1, 0, 0);
  double max_speed = 0;
  for (int k = 0; k < 200; ++k) {
    robot.StepToPose(goal, 0.02);
    max_speed = std::max(max_speed, robot.linear_speed());
  }
  EXPECT_LE(max_speed, 0.05 + 1e-12);
  EXPECT_TRUE(robot.X_WE().translation().isApprox(goal.translation(), 1e-9));
  EXPECT_TRUE(robot.q().empty());
  // holding brakes to rest: the pose stops changing
  robot.StepToPose(Eigen::Isometry3d::Identity(), 0.02);
  for (int k = 0; k < 50; ++k) robot.Hold(0.02);
  const Eigen::Vector3d held = robot.X_WE().translation();
  robot.Hold(0.02);
  EXPECT_TRUE(robot.X_WE().translation().isApprox(held, kTol));
}

TEST(RobotDriverTest, IiwaOnTheDefaultBaseReachesThePlannedStart) {
  DirectScenario s = testing::LoadCoarseScenario();
  s.robot.kind = RobotKind::kIiwa;
  const RigidNeedleModel needle(s.scene.needle.geometry());
  const InsertionPlan plan = MakeInsertionPlan(s.scene.entry_W, s.scene.target_W, needle, 0.01);
  RobotDriver robot(s.robot, plan.CalcFlangePose(0));
  ASSERT_EQ(robot.q().size(), 7u);
  EXPECT_TRUE(robot.X_WE().isApprox(plan.CalcFlangePose(0), 1e-6));
  // inserting 1 cm along the path through IK + joint limits
  for (int k = 1; k <= 100; ++k) robot.StepToPose(plan.CalcFlangePose(1e-4 * k), 0.02);
  for (int k = 0; k < 50; ++k) robot.StepToPose(plan.CalcFlangePose(0.01), 0.02);
  EXPECT_LT((robot.X_WE().translation() - plan.CalcFlangePose(0.01).translation()).norm(), 1e-5);

  // the joint-limit margin is the smallest distance of a joint to its nearer limit, by hand
  const std::vector<double> q = robot.q();
  double margin = INFINITY;
  for (int j = 0; j < 7; ++j)
    margin = std::min({margin, q[j] - s.robot.iiwa.position_lower[j],
                       s.robot.iiwa.position_upper[j] - q[j]});
  EXPECT_DOUBLE_EQ(robot.joint_limit_margin(), margin);
  EXPECT_GT(margin, 0.0);
  // a joint commanded to its limit ends at it (the driver saturates): margin 0
  std::vector<double> at_limit = q;
  at_limit[3] = s.robot.iiwa.position_upper[3] + 0.5;
  for (int k = 0; k < 2000; ++k) robot.StepToJoints(at_limit, 0.02);
  EXPECT_NEAR(robot.joint_limit_margin(), 0.0, 1e-9);
}

TEST(RobotDriverTest, CartesianRobotHasNoJointLimitMargin) {
  DirectScenario s = testing::LoadCoarseScenario();
  const RigidNeedleModel needle(s.scene.needle.geometry());
  const InsertionPlan plan = MakeInsertionPlan(s.scene.entry_W, s.scene.target_W, needle, 0.01);
  const RobotDriver robot(s.robot, plan.CalcFlangePose(0));
  EXPECT_EQ(robot.joint_limit_margin(), std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace nsim
