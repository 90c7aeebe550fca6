#include "common/scene/target_gate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

constexpr double kTol = 1e-12;
constexpr double kH = 0.02;  // frame period (s)

TargetGateConfig MakeConfig() {
  TargetGateConfig c;
  c.max_age = 0.1;
  c.hold_timeout = 0.3;
  c.speed_horizon = 0.2;
  c.max_linear_speed = 0.05;  // at most 1 cm per target
  c.max_angular_speed = 0.5;  // at most 0.1 rad per target
  c.workspace_min_W = Eigen::Vector3d(-0.5, -0.5, -0.5);
  c.workspace_max_W = Eigen::Vector3d(0.5, 0.5, 0.5);
  return c;
}

// a gate that has published frames 0..n-1 at t = k h
TargetGate MakeGate(const TargetGateConfig& config, int n) {
  TargetGate gate(config);
  for (int k = 0; k < n; ++k) gate.NotePublishedFrame(k, k * kH);
  return gate;
}

RobotTarget Target(uint64_t answers, const Eigen::Vector3d& p) {
  RobotTarget t;
  t.answers_seq = answers;
  t.X_WE.translation() = p;
  return t;
}

uint64_t Count(const TargetGate& gate, GateReason r) {
  return gate.counts().by_reason[static_cast<int>(r)];
}

const Eigen::Isometry3d kNow = Eigen::Isometry3d::Identity();

TEST(TargetGateTest, AcceptsAValidTarget) {
  TargetGate gate = MakeGate(MakeConfig(), 10);
  const GateDecision d = gate.Check(Target(9, Eigen::Vector3d(0.001, 0, 0)), 9 * kH, kNow, {});
  EXPECT_TRUE(d.accepted);
  EXPECT_EQ(d.reason, GateReason::kCount);
  EXPECT_TRUE(d.target.X_WE.isApprox(Target(9, Eigen::Vector3d(0.001, 0, 0)).X_WE, kTol));
  EXPECT_EQ(gate.counts().accepted, 1u);
  EXPECT_EQ(gate.counts().rejected(), 0u);
}

TEST(TargetGateTest, RejectsNaNAndNonRigidPoses) {
  TargetGate gate = MakeGate(MakeConfig(), 10);
  RobotTarget t = Target(5, Eigen::Vector3d::Zero());
  t.X_WE.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(gate.Check(t, 5 * kH, kNow, {}).accepted);
  t = Target(5, Eigen::Vector3d::Zero());
  t.bevel_angle = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(gate.Check(t, 5 * kH, kNow, {}).accepted);
  t = Target(5, Eigen::Vector3d::Zero());
  t.X_WE.linear() *= 1.5;  // not a rotation
  EXPECT_FALSE(gate.Check(t, 5 * kH, kNow, {}).accepted);
  EXPECT_EQ(Count(gate, GateReason::kNonFinite), 3u);
  EXPECT_EQ(gate.counts().accepted, 0u);
  EXPECT_TRUE(gate.ShouldHold(5 * kH));  // nothing accepted yet
}

TEST(TargetGateTest, RejectsStaleOutOfOrderAndUnknownFrames) {
  TargetGate gate = MakeGate(MakeConfig(), 20);
  const double now = 19 * kH;
  // frame 10 is 0.18 s old > max_age 0.1 s: stale
  GateDecision d = gate.Check(Target(10, Eigen::Vector3d::Zero()), now, kNow, {});
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, GateReason::kStale);
  // frame 15 is 0.08 s old: fine
  EXPECT_TRUE(gate.Check(Target(15, Eigen::Vector3d::Zero()), now, kNow, {}).accepted);
  // an answer to frame 14 (older than the accepted 15) and a duplicate of 15: out of order
  EXPECT_EQ(gate.Check(Target(14, Eigen::Vector3d::Zero()), now, kNow, {}).reason,
            GateReason::kOutOfOrder);
  EXPECT_EQ(gate.Check(Target(15, Eigen::Vector3d::Zero()), now, kNow, {}).reason,
            GateReason::kOutOfOrder);
  // frame 25 was never published
  EXPECT_EQ(gate.Check(Target(25, Eigen::Vector3d::Zero()), now, kNow, {}).reason,
            GateReason::kUnknownFrame);
  EXPECT_EQ(Count(gate, GateReason::kStale), 1u);
  EXPECT_EQ(Count(gate, GateReason::kOutOfOrder), 2u);
  EXPECT_EQ(Count(gate, GateReason::kUnknownFrame), 1u);
  EXPECT_EQ(gate.counts().received, 5u);
  EXPECT_EQ(gate.counts().accepted, 1u);
  EXPECT_EQ(gate.counts().rejected(), 4u);
}

TEST(TargetGateTest, ClampsTooFastTargetsToTheSpeedLimit) {
  TargetGate gate = MakeGate(MakeConfig(), 10);
  // 5 cm away: 5x the 1 cm a target may ask for
  const GateDecision d = gate.Check(Target(9, Eigen::Vector3d(0.03, 0.04, 0)), 9 * kH, kNow, {});
  EXPECT_TRUE(d.accepted);
  EXPECT_EQ(d.reason, GateReason::kSpeedClamped);
  const double max_move = 0.05 * 0.2;
  EXPECT_TRUE(d.target.X_WE.translation().isApprox(Eigen::Vector3d(0.6, 0.8, 0) * max_move, kTol));
  // a rotation of 1 rad is cut to 0.1 rad about the same axis
  RobotTarget t = Target(9, Eigen::Vector3d::Zero());
  t.answers_seq = 9;
  TargetGate gate2 = MakeGate(MakeConfig(), 10);
  t.X_WE.linear() = ExpSO3(Eigen::Vector3d(0, 0, 1.0));
  const GateDecision r = gate2.Check(t, 9 * kH, kNow, {});
  EXPECT_TRUE(r.accepted);
  EXPECT_TRUE(LogSO3(r.target.X_WE.linear()).isApprox(Eigen::Vector3d(0, 0, 0.1), 1e-9));
  EXPECT_EQ(Count(gate, GateReason::kSpeedClamped), 1u);
}

TEST(TargetGateTest, ClampsIntoTheWorkspaceOrRejectsWhenConfigured) {
  TargetGateConfig config = MakeConfig();
  config.speed_horizon = 100.0;  // speed never limits here
  TargetGate gate = MakeGate(config, 10);
  GateDecision d = gate.Check(Target(9, Eigen::Vector3d(0.9, 0, 0)), 9 * kH, kNow, {});
  EXPECT_TRUE(d.accepted);
  EXPECT_EQ(d.reason, GateReason::kWorkspaceClamped);
  EXPECT_NEAR(d.target.X_WE.translation().x(), 0.5, kTol);

  config.over_limit = OverLimitAction::kReject;
  TargetGate strict = MakeGate(config, 10);
  d = strict.Check(Target(9, Eigen::Vector3d(0.9, 0, 0)), 9 * kH, kNow, {});
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, GateReason::kOverLimit);
  EXPECT_EQ(Count(strict, GateReason::kOverLimit), 1u);
}

TEST(TargetGateTest, HoldsAfterTheTimeoutWithoutValidTargets) {
  TargetGate gate = MakeGate(MakeConfig(), 10);
  ASSERT_TRUE(gate.Check(Target(9, Eigen::Vector3d::Zero()), 9 * kH, kNow, {}).accepted);
  EXPECT_FALSE(gate.ShouldHold(9 * kH + 0.29));
  EXPECT_TRUE(gate.ShouldHold(9 * kH + 0.31));
  EXPECT_TRUE(gate.ShouldHold(std::numeric_limits<double>::quiet_NaN()));  // NaN-safe: hold
}

TEST(TargetGateTest, JointTargetsNeedAJointRobotAndAreLimited) {
  RobotTarget t;
  t.answers_seq = 9;
  t.mode = TargetMode::kJoint;
  t.q = {0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 5.0};
  TargetGate cartesian = MakeGate(MakeConfig(), 10);
  EXPECT_EQ(cartesian.Check(t, 9 * kH, kNow, {}).reason, GateReason::kWrongMode);

  TargetGateConfig config = MakeConfig();
  config.joint_lower.assign(7, -3.0);
  config.joint_upper.assign(7, 3.0);
  config.joint_velocity.assign(7, 1.0);  // at most 0.2 rad per target
  TargetGate gate = MakeGate(config, 10);
  const std::vector<double> q_now(7, 0.0);
  const GateDecision d = gate.Check(t, 9 * kH, kNow, q_now);
  EXPECT_TRUE(d.accepted);
  EXPECT_NEAR(d.target.q[1], 0.2, kTol);  // speed
  EXPECT_NEAR(d.target.q[6], 0.2, kTol);  // clamped to 3, then speed
  EXPECT_EQ(Count(gate, GateReason::kSpeedClamped), 1u);
  EXPECT_EQ(Count(gate, GateReason::kWorkspaceClamped), 1u);
}

TEST(TargetGateTest, ConfigErrorsNameTheKey) {
  TargetGateConfig config = MakeConfig();
  config.max_age = -1;
  try {
    TargetGate gate(config);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "safety.max_age must be > 0 (s), got -1");
  }
}

}  // namespace
}  // namespace nsim
