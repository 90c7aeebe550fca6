#include "common/needle/rigid_needle.h"

#include <gtest/gtest.h>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kTol = 1e-12;  // m and rad: exact kinematics up to round-off

TEST(RigidNeedleTest, TipFollowsFlangeWithToolOffset) {
  NeedleConfig c;
  c.length = 0.15;
  c.p_FBase = Eigen::Vector3d(0.01, 0.0, 0.05);
  const RigidNeedleModel model(c);
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  X_WF.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  X_WF.translation() = Eigen::Vector3d(1, 2, 3);
  RigidNeedleState s;
  ResetRigidNeedle(model, X_WF, s);
  // flange z maps to world -y; base at flange (0.01, 0, 0.05)
  const Eigen::Vector3d base = X_WF * c.p_FBase;
  EXPECT_TRUE(s.p_WBase_start().isApprox(base, kTol));
  EXPECT_TRUE(CalcTipPosition(s.X_WN_start, c.length)
                  .isApprox(base + 0.15 * Eigen::Vector3d(0, -1, 0), kTol));
  Eigen::Isometry3d X_WF2 = X_WF;
  X_WF2.translation() += Eigen::Vector3d(0, 0, 0.01);
  SetRigidNeedleTarget(model, X_WF2, s);
  EXPECT_TRUE(s.p_WBase_start().isApprox(base, kTol));
  EXPECT_TRUE(s.p_WBase_end().isApprox(base + Eigen::Vector3d(0, 0, 0.01), kTol));
  AdvanceRigidNeedle(s);
  EXPECT_TRUE(s.p_WBase_start().isApprox(s.p_WBase_end(), kTol));
}

TEST(RigidNeedleTest, ConfiguredAxisIsTheNeedleZ) {
  NeedleConfig c;
  c.axis_F = Eigen::Vector3d(1, 0, 0);
  const Eigen::Isometry3d X_FN = CalcToolOffset(c);
  EXPECT_TRUE(X_FN.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), kTol));
  EXPECT_NEAR(X_FN.linear().determinant(), 1.0, kTol);
  EXPECT_TRUE((X_FN.linear().transpose() * X_FN.linear()).isIdentity(kTol));
  c.axis_F = Eigen::Vector3d(0, 0, 2);
  EXPECT_TRUE(CalcToolOffset(c).linear().isIdentity(kTol));
}

TEST(RigidNeedleTest, SecondMomentOfArea) {
  EXPECT_NEAR(CalcSecondMomentOfArea(0.723e-3), M_PI * std::pow(0.723e-3, 4) / 4, 1e-25);
}

TEST(RigidNeedleTest, BadConfigNamesTheKey) {
  NeedleConfig c;
  c.length = -1;
  try {
    c.Validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needle.length must be > 0"), std::string::npos);
  }
  c = NeedleConfig{};
  c.axis_F.setZero();
  EXPECT_THROW(RigidNeedleModel{c}, InputError);
  c = NeedleConfig{};
  c.poisson_ratio = 0.5;
  EXPECT_THROW(c.Validate(), InputError);
  RigidNeedleModel model{NeedleConfig{}};
  RigidNeedleState s;
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = std::nan("");
  EXPECT_THROW(SetRigidNeedleTarget(model, bad, s), InputError);
}

}  // namespace
}  // namespace nsim
