#include "common/robot/pose_math.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;    // rounding of a few rotation products
constexpr double kFdStep = 1e-6;       // central-difference step (rad)
constexpr double kFdTolerance = 1e-8;  // O(h^2) truncation + rounding / h

Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

Eigen::Isometry3d RandomPose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = ExpSO3(RandomUnit(rng) * 3.0 * std::abs(u(rng)));
  X.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return X;
}

TEST(PoseMath, ExpMatchesAngleAxisAndSkewIsCross) {
  const Eigen::Vector3d w(0.3, -0.2, 0.5);
  const Eigen::Matrix3d expected = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  EXPECT_LT((ExpSO3(w) - expected).cwiseAbs().maxCoeff(), kRoundoff);
  const Eigen::Vector3d v(1.0, 2.0, -3.0);
  EXPECT_LT((Skew(w) * v - w.cross(v)).norm(), kRoundoff);
  // 90 degrees about z maps x to y
  const Eigen::Vector3d y = ExpSO3(Eigen::Vector3d(0, 0, M_PI / 2)) * Eigen::Vector3d::UnitX();
  EXPECT_LT((y - Eigen::Vector3d::UnitY()).norm(), kRoundoff);
}

TEST(PoseMath, LogInvertsExpOverTheWholeRange) {
  std::mt19937_64 rng(1);
  // angles from tiny to just below pi, including the switch at pi / 2
  for (double angle : {0.0, 1e-12, 1e-7, 1e-3, 0.5, M_PI / 2 - 1e-9, M_PI / 2 + 1e-9, 2.0, 3.0,
                       M_PI - 1e-6, M_PI - 1e-10}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Vector3d w = RandomUnit(rng) * angle;
      const Eigen::Vector3d back = LogSO3(ExpSO3(w));
      EXPECT_LT((back - w).norm(), 1e-9 * std::max(1.0, angle)) << "angle " << angle;
    }
  }
}

TEST(PoseMath, LogAtPiGivesAnAngleOfPi) {
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0, M_PI, 0));
  const Eigen::Vector3d w = LogSO3(R);
  EXPECT_NEAR(w.norm(), M_PI, kRoundoff);
  EXPECT_LT((ExpSO3(w) - R).cwiseAbs().maxCoeff(), kRoundoff);
}

TEST(PoseMath, RightJacobianInverseMatchesCentralDifferences) {
  std::mt19937_64 rng(2);
  for (double angle : {1e-6, 0.3, 1.5, 2.8}) {
    const Eigen::Vector3d phi = RandomUnit(rng) * angle;
    const Eigen::Matrix3d R = ExpSO3(phi);
    Eigen::Matrix3d fd;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d d = Eigen::Vector3d::Unit(j) * kFdStep;
      fd.col(j) = (LogSO3(R * ExpSO3(d)) - LogSO3(R * ExpSO3(-d))) / (2 * kFdStep);
    }
    EXPECT_LT((fd - CalcSO3RightJacobianInverse(phi)).cwiseAbs().maxCoeff(), kFdTolerance)
        << "angle " << angle;
  }
}

TEST(PoseMath, PoseDifferenceInvertsApplyInBothFrames) {
  std::mt19937_64 rng(3);
  for (PoseIncrementFrame frame : {PoseIncrementFrame::kWorldAligned, PoseIncrementFrame::kBody}) {
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::Isometry3d A = RandomPose(rng);
      const Eigen::Isometry3d B = RandomPose(rng);
      const Vector6d d = CalcPoseDifference(A, B, frame);
      const Eigen::Isometry3d A2 = ApplyPoseIncrement(B, d, frame);
      EXPECT_LT((A2.matrix() - A.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
}

TEST(PoseMath, FramesDifferAsExpected) {
  // E rotated 90 degrees about z: a body x step moves along world y
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = ExpSO3(Eigen::Vector3d(0, 0, M_PI / 2));
  Vector6d d = Vector6d::Zero();
  d[kLinear + 0] = 0.1;
  const Eigen::Isometry3d body = ApplyPoseIncrement(X, d, PoseIncrementFrame::kBody);
  const Eigen::Isometry3d world = ApplyPoseIncrement(X, d, PoseIncrementFrame::kWorldAligned);
  EXPECT_LT((body.translation() - Eigen::Vector3d(0, 0.1, 0)).norm(), kRoundoff);
  EXPECT_LT((world.translation() - Eigen::Vector3d(0.1, 0, 0)).norm(), kRoundoff);
  // a world-aligned rotation keeps E's origin in place
  d.setZero();
  d[kAngular + 0] = 0.2;
  X.translation() = Eigen::Vector3d(1, 2, 3);
  EXPECT_LT(
      (ApplyPoseIncrement(X, d, PoseIncrementFrame::kWorldAligned).translation() - X.translation())
          .norm(),
      kRoundoff);
}

TEST(PoseMath, RigidTransformCheck) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(IsRigidTransform(X));
  X.linear()(0, 0) = 1.1;
  EXPECT_FALSE(IsRigidTransform(X));
  X = Eigen::Isometry3d::Identity();
  X.linear() = -Eigen::Matrix3d::Identity();  // a reflection
  EXPECT_FALSE(IsRigidTransform(X));
  X = Eigen::Isometry3d::Identity();
  X.translation().x() = std::nan("");
  EXPECT_FALSE(IsFinitePose(X));
  EXPECT_FALSE(IsRigidTransform(X));
}

TEST(PoseMath, RotationAngle) {
  const Eigen::Matrix3d A = ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3));
  const Eigen::Matrix3d B = ExpSO3(Eigen::Vector3d(0, 0, 0.4)) * A;
  EXPECT_NEAR(CalcRotationAngle(A, B), 0.4, kRoundoff);
}

}  // namespace
}  // namespace nsim
