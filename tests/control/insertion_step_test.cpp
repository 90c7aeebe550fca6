// The bound on the needle's advance per step (common/control/insertion_step.h) against an
// independent construction: the advance as the needle point's motion expressed in the starting
// flange frame (X_from^-1 X_to p_F - p_F along axis_F), a moved-back pose whose advance is the
// bound exactly while its rotation and its motion across the needle are those it had, and
// poses within the bound, retractions and bad input returned bit for bit.
#include "common/control/insertion_step.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace nsim {
namespace {

Eigen::Isometry3d RandomPose(std::mt19937& rng, double translation, double angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  X.linear() = Eigen::AngleAxisd(angle * u(rng), axis).toRotationMatrix();
  X.translation() = translation * Eigen::Vector3d(u(rng), u(rng), u(rng));
  return X;
}

bool Same(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix().array() == b.matrix().array()).all();
}

TEST(InsertionStepTest, TheAdvanceIsTheNeedlePointsMotionAlongItsAxisInTheStartingFrame) {
  std::mt19937 rng(11);
  const Eigen::Vector3d axis_F(0.1, -0.2, 2.0);  // not unit on purpose
  const Eigen::Vector3d p_F(0.01, 0.02, 0.15);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Isometry3d from = RandomPose(rng, 0.5, M_PI);
    const Eigen::Isometry3d to = from * RandomPose(rng, 0.002, 0.02);
    const Eigen::Isometry3d D = from.inverse() * to;
    const double expected = axis_F.normalized().dot(D * p_F - p_F);
    EXPECT_NEAR(CalcNeedleAdvance(axis_F, p_F, from, to), expected, 1e-15) << trial;
  }
  // a pure translation along the needle by s advances it s; a turn about the point, nothing
  const Eigen::Isometry3d from = RandomPose(rng, 0.5, M_PI);
  const Eigen::Vector3d a_W = from.linear() * axis_F.normalized();
  Eigen::Isometry3d along = from;
  along.translation() += 0.003 * a_W;
  EXPECT_NEAR(CalcNeedleAdvance(axis_F, p_F, from, along), 0.003, 1e-15);
  const Eigen::Vector3d p_W = from * p_F;
  const Eigen::Isometry3d turned = Eigen::Translation3d(p_W) *
                                   Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) *
                                   Eigen::Translation3d(-p_W) * from;
  EXPECT_NEAR(CalcNeedleAdvance(axis_F, p_F, from, turned), 0.0, 1e-15);
}

TEST(InsertionStepTest, AFasterAdvanceIsMovedBackOntoTheBoundAndNothingElseChanges) {
  std::mt19937 rng(5);
  const Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d p_F(0.0, 0.0, 0.13);
  const double bound = 0.0002;
  int moved = 0, kept = 0, retracted = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Isometry3d from = RandomPose(rng, 0.5, M_PI);
    const Eigen::Isometry3d to = from * RandomPose(rng, 0.001, 0.01);
    Eigen::Isometry3d limited = to;
    const double advance = CalcNeedleAdvance(axis_F, p_F, from, to);
    const bool changed = LimitNeedleAdvance(axis_F, p_F, from, bound, &limited);
    if (advance <= bound) {
      EXPECT_FALSE(changed) << trial;
      EXPECT_TRUE(Same(limited, to)) << trial;
      (advance < 0 ? retracted : kept)++;
      continue;
    }
    ++moved;
    EXPECT_TRUE(changed) << trial;
    EXPECT_NEAR(CalcNeedleAdvance(axis_F, p_F, from, limited), bound, 1e-15) << trial;
    EXPECT_TRUE((limited.linear().array() == to.linear().array()).all()) << trial;
    // the needle point's motion across the needle (at the starting pose) is the one it had
    const Eigen::Vector3d a_W = from.linear() * axis_F;
    const auto across = [&](const Eigen::Isometry3d& X) {
      const Eigen::Vector3d d = X * p_F - from * p_F;
      return Eigen::Vector3d(d - a_W.dot(d) * a_W);
    };
    EXPECT_LT((across(limited) - across(to)).norm(), 1e-15) << trial;
  }
  EXPECT_GT(moved, 50);
  EXPECT_GT(kept, 10);
  EXPECT_GT(retracted, 50);
}

TEST(InsertionStepTest, NoBoundAndBadInputLeaveThePoseAsItIs) {
  const Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ(), p_F(0, 0, 0.1);
  const Eigen::Isometry3d from = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d to = Eigen::Isometry3d::Identity();
  to.translation() = Eigen::Vector3d(0.0, 0.0, 0.01);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (double bound : {0.0, -0.001, nan, std::numeric_limits<double>::infinity()}) {
    Eigen::Isometry3d X = to;
    EXPECT_FALSE(LimitNeedleAdvance(axis_F, p_F, from, bound, &X)) << bound;
    EXPECT_TRUE(Same(X, to)) << bound;
  }
  Eigen::Isometry3d bad = to;
  bad.translation().x() = nan;
  Eigen::Isometry3d X = bad;
  EXPECT_FALSE(LimitNeedleAdvance(axis_F, p_F, from, 0.001, &X));
  EXPECT_TRUE(X.translation().hasNaN());
  X = to;
  EXPECT_FALSE(LimitNeedleAdvance(Eigen::Vector3d::Zero(), p_F, from, 0.001, &X));
  EXPECT_TRUE(Same(X, to));
}

}  // namespace
}  // namespace nsim
