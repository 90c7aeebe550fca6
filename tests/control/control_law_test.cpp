#include "common/control/control_law.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/control/finite_difference_jacobian.h"
#include "common/control/objectives.h"
#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kRoundoff = 1e-12;

Eigen::MatrixXd RandomMatrix(int m, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd A(m, n);
  for (int i = 0; i < m * n; ++i) A.data()[i] = u(rng);
  return A;
}

// e = A chi + b with A of full row rank: one step maps e to (1 - k) . e, row by row
TEST(ControlLaw, LinearSystemContractsByOneMinusGain) {
  std::mt19937_64 rng(51);
  for (int m : {4, 5, 6}) {
    const Eigen::MatrixXd A = RandomMatrix(m, 6, rng) + 2.0 * Eigen::MatrixXd::Identity(m, 6);
    const Eigen::VectorXd b = RandomMatrix(m, 1, rng);
    Eigen::VectorXd k(m);
    for (int i = 0; i < m; ++i) k[i] = 0.1 + 0.9 * i / (m - 1);  // 0.1 ... 1
    Eigen::VectorXd chi = Eigen::VectorXd::Zero(6);
    Eigen::VectorXd e = A * chi + b;
    for (int it = 0; it < 400; ++it) {
      Eigen::MatrixXd J;
      CalcCentralDifferenceJacobian(
          [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return A * (chi + d) + b; },
          Eigen::VectorXd::Constant(6, 1e-3), &J);
      Eigen::MatrixXd J_r;
      CalcTikhonovPseudoInverse(J, 1e-8, &J_r);
      Eigen::VectorXd delta;
      CalcControlStep(J_r, k, e, &delta);
      chi += delta;
      const Eigen::VectorXd e_next = A * chi + b;
      const Eigen::VectorXd predicted = (1.0 - k.array()) * e.array();
      ASSERT_LT((e_next - predicted).cwiseAbs().maxCoeff(), 1e-9 + 1e-9 * e.norm()) << it;
      e = e_next;
    }
    EXPECT_LT(e.norm(), 1e-12);  // (1 - 0.1)^400 |e0| ~ 5e-19 |e0| on the slowest row
  }
}

// the whole phase-1 loop on a pose: tip position e_p and insertion angle e_a
TEST(ControlLaw, PoseConvergesOnPositionAndAngleObjectives) {
  const Eigen::Vector3d p_ET(0.0, 0.0, 0.15);         // needle tip in E (m)
  const Eigen::Vector3d p_WTarget(0.05, -0.02, 0.2);  // entry target (m)
  const Eigen::Vector3d n_traj = Eigen::Vector3d(0.2, 0.1, -1.0).normalized();
  auto objectives = [&](const Eigen::Isometry3d& X) -> Eigen::VectorXd {
    ObjectiveValues v;
    v.e_p = CalcPositionObjective(p_WTarget, X * p_ET);
    v.e_a = CalcAngleObjective(X.linear() * Eigen::Vector3d::UnitZ(), n_traj);
    Eigen::VectorXd e;
    AssembleObjectiveVector(InsertionPhase::kBeforeSkin, v, &e);
    return e;
  };
  for (PoseIncrementFrame frame : {PoseIncrementFrame::kWorldAligned, PoseIncrementFrame::kBody}) {
    ControlLawConfig config;
    config.frame = frame;
    config.regularization = 1e-8;
    ObjectiveGains gains;
    gains.position = 0.6;
    gains.angle = 0.6;
    Eigen::VectorXd k;
    AssembleGainVector(InsertionPhase::kBeforeSkin, gains, &k);
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = ExpSO3(Eigen::Vector3d(M_PI - 0.4, 0.2, 0.0));  // needle pointing roughly down
    X.translation() = Eigen::Vector3d(0.0, 0.0, 0.4);
    int limited = 0;
    for (int it = 0; it < 100; ++it) {
      Eigen::MatrixXd J;
      const FiniteDifferenceStatus s =
          CalcPoseJacobian(X, Vector6d::Constant(1e-7), frame, objectives, &J);
      ASSERT_TRUE(s.all_finite);
      const CartesianControlOutput out = CalcCartesianTarget(X, J, objectives(X), k, config);
      ASSERT_TRUE(out.valid);
      limited += out.step_limited;
      X = out.X_WE_target;
    }
    const Eigen::VectorXd e = objectives(X);
    EXPECT_GT(limited, 0);  // the first steps exceed the 1 cm / 0.1 rad caps
    EXPECT_LT(e.head<3>().norm(), 1e-9);
    // e_a = |angle| is a cone: its central difference flattens below the step (1e-7 rad)
    EXPECT_LT(e[3], 1e-6);
  }
}

// eq. A.3 on the iiwa: reach a tip position with a 14-evaluation joint Jacobian
TEST(ControlLaw, JointLawDrivesTheIiwaTipToATarget) {
  const Iiwa14Model model;
  const Vector7d q_goal = (Vector7d() << 0.3, 0.6, -0.2, -1.1, 0.4, 0.7, 0.1).finished();
  const Eigen::Vector3d p_target = model.CalcToolPose(q_goal).translation();
  auto objectives = [&](const Vector7d& q) -> Eigen::VectorXd {
    return CalcPositionObjective(p_target, model.CalcToolPose(q).translation());
  };
  ControlLawConfig config;
  config.regularization = 1e-8;
  const Eigen::VectorXd k = Eigen::VectorXd::Constant(3, 0.8);
  Vector7d q = (Vector7d() << 0.0, 0.3, 0.0, -0.8, 0.0, 0.5, 0.0).finished();
  for (int it = 0; it < 60; ++it) {
    Eigen::MatrixXd J;
    EXPECT_EQ(CalcJointJacobian(q, Vector7d::Constant(1e-6), objectives, &J).evaluations, 14);
    const JointControlOutput out = CalcJointTarget(q, J, objectives(q), k, config);
    ASSERT_TRUE(out.valid);
    EXPECT_LE(out.delta.cwiseAbs().maxCoeff(), config.max_joint_step + kRoundoff);
    q = out.q_target;
  }
  EXPECT_LT(objectives(q).norm(), 1e-9);
}

TEST(ControlLaw, StepCapsKeepTheDirection) {
  ControlLawConfig config;
  config.max_translation_step = 0.01;
  config.max_rotation_step = 0.1;
  const Eigen::MatrixXd J = -Eigen::MatrixXd::Identity(6, 6);  // e = target - chi
  Eigen::VectorXd e(6);
  e << 0.3, 0.4, 0.0, 0.0, 0.0, 0.05;  // 0.5 m and 0.05 rad away
  const CartesianControlOutput out =
      CalcCartesianTarget(Eigen::Isometry3d::Identity(), J, e, Eigen::VectorXd::Ones(6), config);
  EXPECT_TRUE(out.step_limited);
  EXPECT_NEAR(out.delta.head<3>().norm(), 0.01, kRoundoff);
  EXPECT_NEAR(out.delta[1] / out.delta[0], 4.0 / 3.0, kRoundoff);
  EXPECT_NEAR(out.delta[5], 0.05 * 0.01 / 0.5, kRoundoff);  // scaled with the rest
  EXPECT_NEAR(out.X_WE_target.translation().x(), 0.006, kRoundoff);
}

TEST(ControlLaw, FaultsHoldTheRobot) {
  ControlLawConfig config;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  Eigen::MatrixXd J = -Eigen::MatrixXd::Identity(4, 6);
  Eigen::VectorXd e = Eigen::VectorXd::Constant(4, 0.001);
  const Eigen::VectorXd k = Eigen::VectorXd::Constant(4, 0.5);
  e[2] = std::nan("");
  CartesianControlOutput out = CalcCartesianTarget(X, J, e, k, config);
  EXPECT_FALSE(out.valid);
  EXPECT_EQ(out.X_WE_target.matrix(), X.matrix());
  e[2] = 0.0;
  J(0, 0) = std::nan("");
  EXPECT_FALSE(CalcCartesianTarget(X, J, e, k, config).valid);
  JointControlOutput jout =
      CalcJointTarget(Vector7d::Zero(), Eigen::MatrixXd::Constant(4, 7, NAN), e, k, config);
  EXPECT_FALSE(jout.valid);
  EXPECT_TRUE(jout.q_target.isZero());
  // programming errors: shapes and gains
  EXPECT_THROW(CalcCartesianTarget(X, Eigen::MatrixXd::Zero(4, 7), e, k, config), InputError);
  EXPECT_THROW(CalcCartesianTarget(X, -Eigen::MatrixXd::Identity(4, 6), e,
                                   Eigen::VectorXd::Constant(3, 0.5), config),
               InputError);
  EXPECT_THROW(CalcCartesianTarget(X, -Eigen::MatrixXd::Identity(4, 6), e,
                                   Eigen::VectorXd::Constant(4, -0.5), config),
               InputError);
  config.regularization = 0.0;
  try {
    config.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& err) {
    EXPECT_STREQ(err.what(), "control.regularization must be > 0, got 0");
  }
}

}  // namespace
}  // namespace nsim
