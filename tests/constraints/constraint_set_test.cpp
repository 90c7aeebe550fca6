#include "common/constraints/constraint_set.h"

#include <gtest/gtest.h>

#include <string>

#include "common/constraints/dense_linear_body.h"
#include "common/core/error.h"
#include "tests/constraints/test_helpers.h"

namespace nsim {
namespace {

using testing::MakeParticleConfig;

constexpr double kRoundOff = 1e-14;  // m or -, values of order 1

Eigen::Matrix3Xd FourPoints() {
  Eigen::Matrix3Xd x(3, 4);
  x << 0, 1, 0, 0,  //
      0, 0, 1, 0,   //
      0, 0, 0, 1;
  return x;
}

template <typename F>
void ExpectInputError(F&& f, const std::string& fragment) {
  try {
    f();
    FAIL() << "expected InputError containing \"" << fragment << "\"";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ConstraintSetTest, TangentBasisIsRightHandedOrthonormal) {
  for (const Eigen::Vector3d& v : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0.3, -2.0, 0.7), Eigen::Vector3d(-1, -1, -1)}) {
    const Eigen::Vector3d n = v.normalized();
    Eigen::Vector3d t1, t2;
    CalcTangentBasis(n, t1, t2);
    EXPECT_NEAR(t1.norm(), 1.0, kRoundOff);
    EXPECT_NEAR(t2.norm(), 1.0, kRoundOff);
    EXPECT_NEAR(t1.dot(n), 0.0, kRoundOff);
    EXPECT_NEAR(t2.dot(n), 0.0, kRoundOff);
    EXPECT_NEAR(n.cross(t1).dot(t2), 1.0, kRoundOff);
  }
}

TEST(ConstraintSetTest, RowValuesFollowTheDefinition) {
  DenseLinearBody body(MakeParticleConfig(FourPoints(), 1.0, 0.01, Eigen::Vector3d::Zero()));
  body.SolveFreeMotion();
  ConstraintSet set;
  const int b = set.AddBody(body);
  const Eigen::Vector4d bary(0.1, 0.2, 0.3, 0.4);
  const int p = set.AddBodyPoint(b, Eigen::Vector4i(0, 1, 2, 3), bary);
  const Eigen::Vector3d xp(0.2, 0.3, 0.4);  // sum of bary_k X_k
  const int k = set.AddKinematicPoint(Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(0.5, 0.0, 0.0));
  EXPECT_LE((set.CalcStartPosition(p) - xp).norm(), kRoundOff);
  EXPECT_LE((set.CalcStartPosition(k) - Eigen::Vector3d(1, 1, 1)).norm(), 0.0);
  EXPECT_LE((set.CalcFreePosition(k) - Eigen::Vector3d(0.5, 0, 0)).norm(), 0.0);

  const Eigen::Vector3d offset(0.01, 0.02, 0.03);
  const int g_bil = set.AddBilateral(p, k, Eigen::Matrix3d::Identity(), offset);
  const int g_fric = set.AddFrictionContact(p, k, Eigen::Vector3d(0, 0, 2), 0.4, 0.005);
  EXPECT_EQ(set.num_rows(), 6);
  EXPECT_EQ(set.group(g_bil).law, ConstraintLaw::kBilateral);
  EXPECT_EQ(set.group(g_fric).law, ConstraintLaw::kFriction);
  EXPECT_EQ(set.group(g_fric).first_row, 3);
  EXPECT_DOUBLE_EQ(set.group(g_fric).mu, 0.4);
  EXPECT_FALSE(set.all_bilateral());

  const std::vector<const Eigen::Matrix3Xd*> x{&body.free_positions()};
  const Eigen::Vector3d rel_end = xp - Eigen::Vector3d(0.5, 0, 0);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(set.CalcRowValue(c, x), rel_end[c] - offset[c], kRoundOff);
  // normal row: n . (x_p - x_k) - gap_min, with the normal normalized
  EXPECT_NEAR(set.CalcRowValue(3, x), rel_end.z() - 0.005, kRoundOff);
  // tangent rows: slip over the step = t . (rel_end - rel_start)
  const Eigen::Vector3d rel_start = xp - Eigen::Vector3d(1, 1, 1);
  for (int r = 4; r < 6; ++r) {
    const Eigen::Vector3d t = set.term(set.row(r).first_term).direction;
    EXPECT_NEAR(t.dot(Eigen::Vector3d::UnitZ()), 0.0, kRoundOff);
    EXPECT_NEAR(set.CalcRowValue(r, x), t.dot(rel_end - rel_start), kRoundOff);
  }
  set.Clear();
  EXPECT_EQ(set.num_rows(), 0);
  EXPECT_EQ(set.num_points(), 0);
  EXPECT_EQ(set.num_bodies(), 0);
  EXPECT_TRUE(set.all_bilateral());
}

TEST(ConstraintSetTest, RejectsBadInput) {
  DenseLinearBody body(MakeParticleConfig(FourPoints(), 1.0, 0.01, Eigen::Vector3d::Zero()));
  ConstraintSet set;
  const int b = set.AddBody(body);
  ExpectInputError([&] { set.AddBody(body); }, "body added twice");
  ExpectInputError([&] { set.AddNodePoint(3, 0); }, "body index must be in [0, 1), got 3");
  ExpectInputError([&] { set.AddNodePoint(b, 4); }, "node index must be in [0, 4), got 4");
  ExpectInputError(
      [&] {
        set.AddBodyPoint(b, std::vector<int>{0, 1}, std::vector<double>{1.0});
      },
      "expected as many weights as nodes (2), got 1");
  ExpectInputError([&] { set.AddBodyPoint(b, std::vector<int>{}, std::vector<double>{}); },
                   "at least one node");
  ExpectInputError(
      [&] { set.AddBodyPoint(b, Eigen::Vector4i(0, 1, 2, 3), Eigen::Vector4d(NAN, 0, 0, 1)); },
      "weight must be finite");
  ExpectInputError(
      [&] { set.AddKinematicPoint(Eigen::Vector3d(INFINITY, 0, 0), Eigen::Vector3d::Zero()); },
      "must be finite");
  const int p = set.AddNodePoint(b, 0);
  const int k = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  ExpectInputError([&] { set.AddContact(p, 9, Eigen::Vector3d::UnitZ()); },
                   "second point index must be in [0, 2), got 9");
  ExpectInputError([&] { set.AddContact(p, k, Eigen::Vector3d::Zero()); }, "normal must be");
  ExpectInputError([&] { set.AddFrictionContact(p, k, Eigen::Vector3d::UnitZ(), -0.1); },
                   "mu must be >= 0, got -0.1");
  ExpectInputError([&] { set.AddBilateral(p, k, Eigen::Matrix3Xd(3, 4)); },
                   "takes 1-3 directions, got 4");
  ExpectInputError([&] { set.AddBilateral(p, k, Eigen::Vector3d::Zero()); },
                   "direction must be finite and nonzero");
  EXPECT_EQ(set.num_rows(), 0);
  set.AddRow({{p, Eigen::Vector3d::UnitX()}}, 0.0);
  set.AddRow({{p, Eigen::Vector3d::UnitY()}}, 0.0);
  ExpectInputError([&] { set.AddGroup(ConstraintLaw::kUnilateral, 1); },
                   "must take all 2 ungrouped rows, got 1");
  ExpectInputError([&] { set.AddGroup(ConstraintLaw::kFriction, 2, 0.1); },
                   "expects 3-3 rows, got 2");
  EXPECT_EQ(set.AddGroup(ConstraintLaw::kBilateral, 2), 0);
}

}  // namespace
}  // namespace nsim
