#include "common/robot/iiwa14_ik.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

Vector7d RandomJoints(const Iiwa14Model& model, std::mt19937_64& rng, double margin) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Vector7d q;
  for (int i = 0; i < 7; ++i) {
    const double lo = model.config().position_lower[i] + margin;
    const double hi = model.config().position_upper[i] - margin;
    q[i] = lo + u(rng) * (hi - lo);
  }
  return q;
}

Iiwa14Config MakeConfig() {
  Iiwa14Config c;
  c.X_WB.translation() = Eigen::Vector3d(0.2, -0.1, 0.7);
  c.X_WB.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  c.X_FT.translation() = Eigen::Vector3d(0.0, 0.0, 0.18);
  return c;
}

// reachable poses: FK of random in-limit joints; seeds: other random in-limit joints
TEST(Iiwa14Ik, ReachesRandomReachablePosesWithinTolerance) {
  const Iiwa14Model model(MakeConfig());
  const Iiwa14IkConfig config;
  const Iiwa14InverseKinematics ik(model, config);
  std::mt19937_64 rng(21);
  constexpr int kTrials = 300;
  int successes = 0, restarts = 0;
  double worst_p = 0, worst_r = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const Vector7d q_true = RandomJoints(model, rng, 0.0);
    const Eigen::Isometry3d X_target = model.CalcToolPose(q_true);
    const Vector7d seed = RandomJoints(model, rng, 0.0);
    const Iiwa14IkResult r = ik.Solve(X_target, seed);
    ASSERT_TRUE(model.IsWithinLimits(r.q)) << "trial " << trial;
    // the reported residual is the true one
    const Eigen::Isometry3d X = model.CalcToolPose(r.q);
    EXPECT_NEAR((X.translation() - X_target.translation()).norm(), r.position_error, 1e-12);
    EXPECT_NEAR(CalcRotationAngle(X.linear(), X_target.linear()), r.orientation_error, 1e-12);
    successes += r.success;
    restarts += r.restarts;
    if (r.success) {
      worst_p = std::max(worst_p, r.position_error);
      worst_r = std::max(worst_r, r.orientation_error);
    }
  }
  EXPECT_EQ(successes, kTrials);
  EXPECT_LE(worst_p, config.position_tolerance);
  EXPECT_LE(worst_r, config.orientation_tolerance);
  RecordProperty("restarts", restarts);
  std::printf("IK: %d / %d reached, %d restarts, worst %.2e m %.2e rad\n", successes, kTrials,
              restarts, worst_p, worst_r);
}

TEST(Iiwa14Ik, NearbySeedConvergesWithoutRestart) {
  const Iiwa14Model model(MakeConfig());
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  std::mt19937_64 rng(22);
  std::normal_distribution<double> g(0.0, 0.05);
  for (int trial = 0; trial < 100; ++trial) {
    const Vector7d q_true = RandomJoints(model, rng, 0.2);
    Vector7d seed = q_true;
    for (int j = 0; j < 7; ++j) seed[j] += g(rng);
    const Iiwa14IkResult r = ik.Solve(model.CalcToolPose(q_true), seed);
    EXPECT_TRUE(r.success);
    EXPECT_EQ(r.restarts, 0);
    EXPECT_LE(r.iterations, 20);
  }
}

TEST(Iiwa14Ik, TargetsAtTheJointLimitsAreReachedInsideThem) {
  const Iiwa14Model model(MakeConfig());
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  std::mt19937_64 rng(23);
  for (int trial = 0; trial < 50; ++trial) {
    Vector7d q_true = RandomJoints(model, rng, 0.0);
    // put two joints exactly on a bound
    q_true[trial % 7] = model.config().position_upper[trial % 7];
    q_true[(trial + 3) % 7] = model.config().position_lower[(trial + 3) % 7];
    const Iiwa14IkResult r = ik.Solve(model.CalcToolPose(q_true), Vector7d::Zero());
    EXPECT_TRUE(r.success) << "trial " << trial;
    EXPECT_TRUE(model.IsWithinLimits(r.q));
  }
}

TEST(Iiwa14Ik, ReportsUnreachablePosesWithTheResidual) {
  const Iiwa14Model model(MakeConfig());
  Iiwa14IkConfig config;
  config.max_restarts = 5;
  const Iiwa14InverseKinematics ik(model, config);
  // 3 m along the base x axis at shoulder height, tool z along base x: the best the arm can do
  // is to stretch along x (q2 = 90 deg), 0.42 + 0.40 + 0.126 + 0.18 = 1.126 m from the shoulder
  const Eigen::Isometry3d& X_WB = model.config().X_WB;
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.linear() = X_WB.linear() * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY());
  far.translation() = X_WB * Eigen::Vector3d(3.0, 0.0, 0.36);
  const double gap = 3.0 - 1.126;  // m
  Iiwa14IkResult r = ik.Solve(far, Vector7d::Zero());
  EXPECT_FALSE(r.success);
  EXPECT_TRUE(model.IsWithinLimits(r.q));
  EXPECT_GE(r.position_error, gap - 1e-12);  // nothing can beat the reach
  EXPECT_LT(r.position_error, gap + 1e-6);   // and the best reach is found
  // the stretched arm is singular: the descent slows down there, so only roughly aligned
  EXPECT_LT(r.orientation_error, 1e-3);
  // a NaN target is a failure, not a crash
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = std::nan("");
  r = ik.Solve(bad, Vector7d::Zero());
  EXPECT_FALSE(r.success);
  EXPECT_TRUE(std::isinf(r.position_error));
  EXPECT_TRUE(model.IsWithinLimits(r.q));
}

TEST(Iiwa14Ik, IsDeterministic) {
  const Iiwa14Model model(MakeConfig());
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  std::mt19937_64 rng(24);
  const Eigen::Isometry3d X = model.CalcToolPose(RandomJoints(model, rng, 0.0));
  const Vector7d seed = RandomJoints(model, rng, 0.0);
  const Iiwa14IkResult a = ik.Solve(X, seed), b = ik.Solve(X, seed);
  EXPECT_EQ(a.q, b.q);
  EXPECT_EQ(a.iterations, b.iterations);
}

TEST(Iiwa14Ik, BadConfigMessages) {
  Iiwa14IkConfig c;
  c.null_space_gain = 2.0;
  try {
    c.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "ik.null_space_gain must be in [0, 1], got 2");
  }
  c = Iiwa14IkConfig();
  c.position_tolerance = 0.0;
  const Iiwa14Model model;
  EXPECT_THROW(Iiwa14InverseKinematics(model, c), InputError);
}

}  // namespace
}  // namespace nsim
