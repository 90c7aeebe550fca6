// The needle tilt bound (common/control/needle_tilt.h) against independent constructions: the
// turned axis is the spherical interpolation (slerp) of the needle axis toward the planned
// direction that leaves exactly the bound, the pivot keeps its place on the needle (its
// coordinates in the flange frame), and a pose within the bound is returned bit for bit.
#include "common/control/needle_tilt.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace nsim {
namespace {

Eigen::Isometry3d RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
  X.translation() = 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  return X;
}

// the unit vector a turned toward d through the angle `turn` in their plane (slerp)
Eigen::Vector3d Slerp(const Eigen::Vector3d& a, const Eigen::Vector3d& d, double turn) {
  const double angle = std::acos(std::clamp(a.dot(d), -1.0, 1.0));
  const double t = turn / angle;
  return (std::sin((1 - t) * angle) * a + std::sin(t * angle) * d) / std::sin(angle);
}

TEST(NeedleTiltTest, TiltedPosesTurnOntoTheBoundByTheSmallestTurnAboutThePivot) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d axis_F = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
  int turned = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Isometry3d X = RandomPose(rng);
    const Eigen::Vector3d direction(u(rng), u(rng), u(rng));  // not unit on purpose
    const Eigen::Vector3d pivot = 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const double bound = 0.05 + 0.5 * (1 + u(rng));
    const Eigen::Isometry3d before = X;
    const double tilt = CalcNeedleTilt(before, axis_F, direction);
    const bool changed = LimitNeedleTilt(axis_F, direction, pivot, bound, &X);
    if (tilt <= bound) {
      EXPECT_FALSE(changed);
      EXPECT_TRUE((X.matrix().array() == before.matrix().array()).all()) << trial;
      continue;
    }
    ++turned;
    EXPECT_TRUE(changed);
    EXPECT_NEAR(CalcNeedleTilt(X, axis_F, direction), bound, 1e-12) << trial;
    const Eigen::Vector3d expected =
        Slerp(before.linear() * axis_F, direction.normalized(), tilt - bound);
    EXPECT_LT((X.linear() * axis_F - expected).norm(), 1e-12) << trial;
    // a rotation about the pivot: the pivot's flange coordinates do not change
    EXPECT_LT((X.inverse() * pivot - before.inverse() * pivot).norm(), 1e-14) << trial;
    EXPECT_NEAR((X.linear().transpose() * X.linear() - Eigen::Matrix3d::Identity()).norm(), 0.0,
                1e-14);
  }
  EXPECT_GT(turned, 50);
}

TEST(NeedleTiltTest, AnAntiparallelNeedleTurnsOntoTheBoundToo) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(CalcNeedleTilt(X, axis_F, -Eigen::Vector3d::UnitZ()), M_PI, 1e-15);
  EXPECT_TRUE(LimitNeedleTilt(axis_F, -Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.3, &X));
  EXPECT_NEAR(CalcNeedleTilt(X, axis_F, -Eigen::Vector3d::UnitZ()), 0.3, 1e-12);
}

TEST(NeedleTiltTest, BadInputLeavesThePoseUnchanged) {
  const Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ();
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Isometry3d before = X;
  const Eigen::Vector3d d = Eigen::Vector3d::UnitZ(), p = Eigen::Vector3d::Zero();
  const double nan = std::nan("");
  EXPECT_FALSE(LimitNeedleTilt(axis_F, d, p, 0.0, &X));
  EXPECT_FALSE(LimitNeedleTilt(axis_F, d, p, nan, &X));
  EXPECT_FALSE(LimitNeedleTilt(axis_F, Eigen::Vector3d(nan, 0, 1), p, 0.1, &X));
  EXPECT_FALSE(LimitNeedleTilt(axis_F, d, Eigen::Vector3d(0, nan, 0), 0.1, &X));
  EXPECT_TRUE((X.matrix().array() == before.matrix().array()).all());
  EXPECT_TRUE(LimitNeedleTilt(axis_F, d, p, 0.1, &X));  // the same pose, a valid bound
}

}  // namespace
}  // namespace nsim
