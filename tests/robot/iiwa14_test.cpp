#include "common/robot/iiwa14.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;    // a chain of 7 rotations, lengths ~1 m
constexpr double kFdStep = 1e-6;       // rad
constexpr double kFdTolerance = 1e-8;  // O(h^2) + rounding / h, lengths ~1 m
constexpr double kHalfPi = M_PI / 2;

Eigen::Matrix3d Ry(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d Rz(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Vector7d Joints(std::initializer_list<std::pair<int, double>> set) {
  Vector7d q = Vector7d::Zero();
  for (const auto& [i, v] : set) q[i] = v;
  return q;
}

void ExpectPose(const Eigen::Isometry3d& X, const Eigen::Vector3d& p, const Eigen::Matrix3d& R) {
  EXPECT_LT((X.translation() - p).norm(), kRoundoff) << X.translation().transpose();
  EXPECT_LT((X.linear() - R).cwiseAbs().maxCoeff(), kRoundoff);
}

Vector7d RandomJoints(const Iiwa14Model& model, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Vector7d q;
  for (int i = 0; i < 7; ++i) {
    q[i] = model.config().position_lower[i] +
           u(rng) * (model.config().position_upper[i] - model.config().position_lower[i]);
  }
  return q;
}

TEST(Iiwa14, FlangePosesByHand) {
  const Iiwa14Model model;
  const double reach = 0.42 + 0.40 + 0.126;  // elbow to flange (m)
  // all zeros: straight up, 0.36 + 0.42 + 0.40 + 0.126
  ExpectPose(model.CalcFlangePoseInBase(Vector7d::Zero()), {0, 0, 1.306},
             Eigen::Matrix3d::Identity());
  // a2 = +90 deg about +y: the arm lies along +x from the shoulder at z = 0.36
  ExpectPose(model.CalcFlangePoseInBase(Joints({{1, kHalfPi}})), {reach, 0, 0.36}, Ry(kHalfPi));
  // a1 = +90 deg then a2 = +90 deg: along +y
  ExpectPose(model.CalcFlangePoseInBase(Joints({{0, kHalfPi}, {1, kHalfPi}})), {0, reach, 0.36},
             Rz(kHalfPi) * Ry(kHalfPi));
  // a4 = +90 deg about -y at z = 0.78: the forearm points along -x
  ExpectPose(model.CalcFlangePoseInBase(Joints({{3, kHalfPi}})), {-(0.40 + 0.126), 0, 0.78},
             Ry(-kHalfPi));
  // a6 = +90 deg about +y at z = 1.18: the flange sticks out along +x
  ExpectPose(model.CalcFlangePoseInBase(Joints({{5, kHalfPi}})), {0.126, 0, 1.18}, Ry(kHalfPi));
  // a7 only turns the flange
  ExpectPose(model.CalcFlangePoseInBase(Joints({{6, 0.5}})), {0, 0, 1.306}, Rz(0.5));
  // a2 = 90 and a4 = 90 folds the forearm back up: elbow at (0.42, 0, 0.36), then +z
  ExpectPose(model.CalcFlangePoseInBase(Joints({{1, kHalfPi}, {3, kHalfPi}})),
             {0.42, 0, 0.36 + 0.526}, Eigen::Matrix3d::Identity());
}

TEST(Iiwa14, LinkFramesAxesAndOrigins) {
  const Iiwa14Model model;
  Iiwa14Kinematics kin;
  model.CalcForwardKinematics(Joints({{1, kHalfPi}}), &kin);
  EXPECT_LT((kin.p_WJ[1] - Eigen::Vector3d(0, 0, 0.36)).norm(), kRoundoff);     // a2
  EXPECT_LT((kin.p_WJ[3] - Eigen::Vector3d(0.42, 0, 0.36)).norm(), kRoundoff);  // a4 (elbow)
  EXPECT_LT((kin.p_WJ[5] - Eigen::Vector3d(0.82, 0, 0.36)).norm(), kRoundoff);  // a6 (wrist)
  EXPECT_LT((kin.a_W[2] - Eigen::Vector3d::UnitX()).norm(), kRoundoff);         // a3 along the arm
  EXPECT_LT((kin.a_W[3] - -Eigen::Vector3d::UnitY()).norm(), kRoundoff);
  EXPECT_LT((kin.X_WL[1].translation() - Eigen::Vector3d(0, 0, 0.36)).norm(), kRoundoff);
  EXPECT_LT((kin.X_WF.matrix() - model.CalcFlangePoseInBase(kin.q).matrix()).cwiseAbs().maxCoeff(),
            kRoundoff);
}

TEST(Iiwa14, BaseAndToolOffsets) {
  Iiwa14Config c;
  c.X_WB.linear() = Rz(0.7);
  c.X_WB.translation() = Eigen::Vector3d(0.5, -0.2, 0.8);
  c.X_FT.translation() = Eigen::Vector3d(0, 0, 0.15);  // a 15 cm needle holder along flange z
  const Iiwa14Model model(c);
  std::mt19937_64 rng(4);
  for (int trial = 0; trial < 20; ++trial) {
    const Vector7d q = RandomJoints(model, rng);
    Iiwa14Kinematics kin;
    model.CalcForwardKinematics(q, &kin);
    const Eigen::Isometry3d expected = c.X_WB * model.CalcFlangePoseInBase(q) * c.X_FT;
    EXPECT_LT((kin.X_WT.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), kRoundoff);
    EXPECT_LT((model.CalcToolPose(q).matrix() - expected.matrix()).cwiseAbs().maxCoeff(),
              kRoundoff);
    EXPECT_NEAR((kin.X_WT.translation() - kin.X_WF.translation()).norm(), 0.15, kRoundoff);
  }
  // all zeros: tool straight above the base origin, 1.306 + 0.15 up
  ExpectPose(model.CalcToolPose(Vector7d::Zero()), Eigen::Vector3d(0.5, -0.2, 0.8 + 1.456),
             Rz(0.7));
}

TEST(Iiwa14, JacobianMatchesCentralDifferences) {
  Iiwa14Config c;
  c.X_WB.linear() = Rz(-0.3) * Ry(0.2);
  c.X_WB.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  c.X_FT.translation() = Eigen::Vector3d(0.01, 0, 0.2);
  const Iiwa14Model model(c);
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 50; ++trial) {
    const Vector7d q = RandomJoints(model, rng);
    Iiwa14Kinematics kin;
    model.CalcForwardKinematics(q, &kin);
    Jacobian67 J;
    model.CalcToolJacobian(kin, &J);
    // also at another point fixed to link 7, 5 cm off the tool
    const Eigen::Vector3d p_TP(0.05, -0.02, 0.0);
    Jacobian67 J_P;
    model.CalcJacobian(kin, kin.X_WT * p_TP, &J_P);
    Jacobian67 fd, fd_P;
    for (int j = 0; j < 7; ++j) {
      Vector7d qp = q, qm = q;
      qp[j] += kFdStep;
      qm[j] -= kFdStep;
      const Eigen::Isometry3d Xp = model.CalcToolPose(qp), Xm = model.CalcToolPose(qm);
      fd.block<3, 1>(kLinear, j) = (Xp.translation() - Xm.translation()) / (2 * kFdStep);
      fd.block<3, 1>(kAngular, j) = LogSO3(Xp.linear() * Xm.linear().transpose()) / (2 * kFdStep);
      fd_P.block<3, 1>(kLinear, j) = (Xp * p_TP - Xm * p_TP) / (2 * kFdStep);
      fd_P.block<3, 1>(kAngular, j) = fd.block<3, 1>(kAngular, j);
    }
    EXPECT_LT((fd - J).cwiseAbs().maxCoeff(), kFdTolerance) << "trial " << trial;
    EXPECT_LT((fd_P - J_P).cwiseAbs().maxCoeff(), kFdTolerance) << "trial " << trial;
  }
}

TEST(Iiwa14, LimitsFromTheReferenceTable) {
  const Iiwa14Model model;
  const Iiwa14Config& c = model.config();
  EXPECT_DOUBLE_EQ(c.position_upper[0], 2.9668);
  EXPECT_DOUBLE_EQ(c.position_upper[1], 2.0942);
  EXPECT_DOUBLE_EQ(c.position_upper[6], 3.0541);
  EXPECT_DOUBLE_EQ(c.velocity_limit[3], 1.3089);
  EXPECT_DOUBLE_EQ(c.acceleration_limit[4], 12.23);
  EXPECT_TRUE((c.position_lower + c.position_upper).isZero());
  Vector7d q = Vector7d::Constant(10.0);
  EXPECT_FALSE(model.IsWithinLimits(q));
  EXPECT_TRUE(model.IsWithinLimits(model.ClampToLimits(q)));
  EXPECT_TRUE((model.ClampToLimits(q) - c.position_upper).isZero());
  q[0] = std::nan("");
  EXPECT_FALSE(model.IsWithinLimits(q));
  EXPECT_TRUE(model.CalcMidRange().isZero());
}

TEST(Iiwa14, BadConfigMessages) {
  Iiwa14Config c;
  c.velocity_limit[2] = 0.0;
  try {
    c.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "iiwa.velocity_limit[2] must be > 0 (rad/s), got 0");
  }
  c = Iiwa14Config();
  c.position_lower[4] = 3.0;
  EXPECT_THROW(Iiwa14Model{c}, InputError);
  c = Iiwa14Config();
  c.X_FT.linear() *= 2.0;
  EXPECT_THROW(Iiwa14Model{c}, InputError);
}

}  // namespace
}  // namespace nsim
