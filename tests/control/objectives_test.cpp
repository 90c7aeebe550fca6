#include "common/control/objectives.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-15;

TEST(Objectives, PositionIsTargetMinusTip) {
  const Eigen::Vector3d e = CalcPositionObjective({0.1, 0.2, 0.3}, {0.1, 0.25, 0.0});
  EXPECT_LT((e - Eigen::Vector3d(0.0, -0.05, 0.3)).norm(), kRoundoff);
}

TEST(Objectives, AngleByHand) {
  EXPECT_NEAR(CalcAngleObjective({0, 0, 1}, {0, 0, 1}), 0.0, kRoundoff);
  EXPECT_NEAR(CalcAngleObjective({0, 0, 1}, {1, 0, 0}), M_PI / 2, kRoundoff);
  EXPECT_NEAR(CalcAngleObjective({0, 0, 1}, {0, 0, -3}), M_PI, kRoundoff);
  // 30 degrees; inputs need not be unit
  EXPECT_NEAR(CalcAngleObjective({0, 0, 2}, {0.5, 0, std::sqrt(3.0) / 2}), M_PI / 6, 1e-15);
  EXPECT_NEAR(CalcAngleObjective({1, 1, 0}, {1, 0, 0}), M_PI / 4, 1e-15);
  EXPECT_TRUE(std::isnan(CalcAngleObjective({0, 0, 0}, {1, 0, 0})));
  EXPECT_TRUE(std::isnan(CalcAngleObjective({0, std::nan(""), 1}, {1, 0, 0})));
}

// arccos loses the angle below ~1e-8 rad; atan2 keeps it
TEST(Objectives, AngleIsAccurateNearAlignment) {
  for (double angle : {1e-12, 1e-9, 1e-6}) {
    const Eigen::Vector3d n(0, 0, 1);
    const Eigen::Vector3d m(std::sin(angle), 0, std::cos(angle));
    EXPECT_NEAR(CalcAngleObjective(n, m), angle, 1e-3 * angle) << angle;
    // near anti-alignment too
    EXPECT_NEAR(CalcAngleObjective(n, -m), M_PI - angle, 1e-15) << angle;
  }
  // what arccos would return at 1e-9 rad: the dot product rounds to 1
  EXPECT_EQ(std::acos(std::cos(1e-9)), 0.0);
}

TEST(Objectives, EntryByHand) {
  // skin plane z = 0.1 with normal +z: u = x, v = y
  const SkinPlane plane = MakeSkinPlane({0.0, 0.0, 0.1}, {0, 0, 2});
  EXPECT_LT((plane.u_W - Eigen::Vector3d::UnitX()).norm(), kRoundoff);
  EXPECT_LT((plane.v_W - Eigen::Vector3d::UnitY()).norm(), kRoundoff);
  const Eigen::Vector2d e = CalcEntryObjective(plane, {0.003, -0.002, 0.5});
  EXPECT_LT((e - Eigen::Vector2d(0.003, -0.002)).norm(), kRoundoff);  // normal part dropped
  // tilted plane, normal (1, 0, 1)/sqrt2: u = (1, 0, -1)/sqrt2, v = n x u = (0, 1, 0)
  const SkinPlane tilted = MakeSkinPlane({1, 1, 1}, {1, 0, 1});
  EXPECT_LT((tilted.u_W - Eigen::Vector3d(1, 0, -1) / std::sqrt(2.0)).norm(), 1e-15);
  EXPECT_LT((tilted.v_W - Eigen::Vector3d(0, 1, 0)).norm(), 1e-15);
  const Eigen::Vector2d et =
      CalcEntryObjective(tilted, Eigen::Vector3d(1, 1, 1) + Eigen::Vector3d(0.01, 0.02, 0.0));
  EXPECT_NEAR(et[0], 0.01 / std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(et[1], 0.02, 1e-15);
  // a normal along x uses the world y axis for u
  const SkinPlane side = MakeSkinPlane({0, 0, 0}, {-1, 0, 0});
  EXPECT_LT((side.u_W - Eigen::Vector3d::UnitY()).norm(), kRoundoff);
  EXPECT_NEAR(side.u_W.cross(side.v_W).dot(side.n_W), 1.0, kRoundoff);  // right-handed
  EXPECT_THROW(MakeSkinPlane({0, 0, 0}, {0, 0, 0}), InputError);
}

TEST(Objectives, PhaseRowCountsAndLayout) {
  EXPECT_EQ(DetermineInsertionPhase(false, false), InsertionPhase::kBeforeSkin);
  EXPECT_EQ(DetermineInsertionPhase(true, false), InsertionPhase::kInSkin);
  EXPECT_EQ(DetermineInsertionPhase(true, true), InsertionPhase::kInLiver);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kBeforeSkin).rows, 4);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInSkin).rows, 6);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver).rows, 5);

  ObjectiveValues v;
  v.e_p = Eigen::Vector3d(1, 2, 3);
  v.e_a = 4;
  v.e_e = Eigen::Vector2d(5, 6);
  Eigen::VectorXd e;
  AssembleObjectiveVector(InsertionPhase::kBeforeSkin, v, &e);
  EXPECT_EQ(e, (Eigen::VectorXd(4) << 1, 2, 3, 4).finished());
  AssembleObjectiveVector(InsertionPhase::kInSkin, v, &e);
  EXPECT_EQ(e, (Eigen::VectorXd(6) << 1, 2, 3, 4, 5, 6).finished());
  AssembleObjectiveVector(InsertionPhase::kInLiver, v, &e);
  EXPECT_EQ(e, (Eigen::VectorXd(5) << 1, 2, 3, 5, 6).finished());

  ObjectiveGains g;
  g.position = 0.9;
  g.angle = 0.5;
  g.entry = 0.2;
  Eigen::VectorXd k;
  AssembleGainVector(InsertionPhase::kInSkin, g, &k);
  EXPECT_EQ(k, (Eigen::VectorXd(6) << 0.9, 0.9, 0.9, 0.5, 0.2, 0.2).finished());
  AssembleGainVector(InsertionPhase::kInLiver, g, &k);
  EXPECT_EQ(k, (Eigen::VectorXd(5) << 0.9, 0.9, 0.9, 0.2, 0.2).finished());

  // e_a kept in the liver (a flexible needle's direction): the layout of the skin phase
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, true).rows, 6);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, true).angle_row, 3);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInSkin, true).rows, 6);  // only phase 3 changes
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kBeforeSkin, true).rows, 4);
  AssembleObjectiveVector(InsertionPhase::kInLiver, v, &e, true);
  EXPECT_EQ(e, (Eigen::VectorXd(6) << 1, 2, 3, 4, 5, 6).finished());
  AssembleGainVector(InsertionPhase::kInLiver, g, &k, true);
  EXPECT_EQ(k, (Eigen::VectorXd(6) << 0.9, 0.9, 0.9, 0.5, 0.2, 0.2).finished());

  // e_l (the liver's load) appended in the liver only, after e_e, with or without e_a
  v.e_l = Eigen::Vector2d(7, 8);
  g.load = 0.3;
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, false, true).rows, 7);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, false, true).load_row, 5);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, true, true).rows, 8);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver, true, true).load_row, 6);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInLiver).load_row, -1);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInSkin, false, true).rows, 6);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kInSkin, false, true).load_row, -1);
  EXPECT_EQ(GetObjectiveLayout(InsertionPhase::kBeforeSkin, false, true).rows, 4);
  AssembleObjectiveVector(InsertionPhase::kInLiver, v, &e, false, true);
  EXPECT_EQ(e, (Eigen::VectorXd(7) << 1, 2, 3, 5, 6, 7, 8).finished());
  AssembleObjectiveVector(InsertionPhase::kInLiver, v, &e, true, true);
  EXPECT_EQ(e, (Eigen::VectorXd(8) << 1, 2, 3, 4, 5, 6, 7, 8).finished());
  AssembleObjectiveVector(InsertionPhase::kInSkin, v, &e, false, true);
  EXPECT_EQ(e, (Eigen::VectorXd(6) << 1, 2, 3, 4, 5, 6).finished());
  AssembleGainVector(InsertionPhase::kInLiver, g, &k, false, true);
  EXPECT_EQ(k, (Eigen::VectorXd(7) << 0.9, 0.9, 0.9, 0.2, 0.2, 0.3, 0.3).finished());
}

TEST(Objectives, GainValidation) {
  ObjectiveGains g;
  g.angle = 0.0;
  try {
    g.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "control.gains.angle must be in (0, 1], got 0");
  }
  g.angle = 1.0;
  EXPECT_NO_THROW(g.Validate());
  g.entry = 1.5;
  EXPECT_THROW(g.Validate(), InputError);
  g.entry = 1.0;
  g.load = -0.1;
  try {
    g.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "control.gains.load must be in (0, 1], got -0.1");
  }
}

}  // namespace
}  // namespace nsim
