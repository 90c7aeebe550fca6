#include "common/control/finite_difference_jacobian.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace nsim {
namespace {

constexpr double kAffineTolerance = 1e-11;  // rounding eps |e| / h for |e| ~ 1, h ~ 1e-3
constexpr double kRoundoff = 1e-14;

Eigen::MatrixXd RandomMatrix(int m, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd A(m, n);
  for (int i = 0; i < m * n; ++i) A.data()[i] = u(rng);
  return A;
}

TEST(FiniteDifferenceJacobian, AffineSystemGivesItsMatrix) {
  std::mt19937_64 rng(41);
  for (int n : {6, 7}) {
    for (int m : {4, 5, 6}) {
      const Eigen::MatrixXd A = RandomMatrix(m, n, rng);
      const Eigen::VectorXd b = RandomMatrix(m, 1, rng);
      const Eigen::VectorXd chi = RandomMatrix(n, 1, rng);
      Eigen::VectorXd steps(n);
      for (int j = 0; j < n; ++j) steps[j] = 1e-3 * (1 + j);  // per-DoF steps
      Eigen::MatrixXd J;
      const FiniteDifferenceStatus status = CalcCentralDifferenceJacobian(
          [&](const Eigen::VectorXd& delta) -> Eigen::VectorXd { return A * (chi + delta) + b; },
          steps, &J);
      EXPECT_EQ(status.evaluations, 2 * n);  // 12 for a pose, 14 for the iiwa
      EXPECT_TRUE(status.all_finite);
      ASSERT_EQ(J.rows(), m);
      EXPECT_LT((J - A).cwiseAbs().maxCoeff(), kAffineTolerance);
    }
  }
}

// e(x) = [sin(x0) x1 + exp(x2); x0^3 - cos(x1 x2); tanh(x0 + 2 x1 - x2)] at x0 + delta
TEST(FiniteDifferenceJacobian, SmoothSystemConvergesAtSecondOrder) {
  const Eigen::Vector3d x0(0.3, -0.7, 0.2);
  auto e = [&](const Eigen::VectorXd& delta) -> Eigen::VectorXd {
    const Eigen::Vector3d x = x0 + delta;
    return Eigen::Vector3d(std::sin(x[0]) * x[1] + std::exp(x[2]),
                           x[0] * x[0] * x[0] - std::cos(x[1] * x[2]),
                           std::tanh(x[0] + 2 * x[1] - x[2]));
  };
  Eigen::Matrix3d analytic;
  const double t = 1.0 - std::pow(std::tanh(x0[0] + 2 * x0[1] - x0[2]), 2);
  const double s = std::sin(x0[1] * x0[2]);
  analytic << std::cos(x0[0]) * x0[1], std::sin(x0[0]), std::exp(x0[2]),  //
      3 * x0[0] * x0[0], s * x0[2], s * x0[1],                            //
      t, 2 * t, -t;
  double previous = 0.0;
  for (double h : {1e-2, 5e-3, 2.5e-3}) {
    Eigen::MatrixXd J;
    CalcCentralDifferenceJacobian(e, Eigen::VectorXd::Constant(3, h), &J);
    const double error = (J - analytic).cwiseAbs().maxCoeff();
    EXPECT_LT(error, 1.01 * h * h);  // max |third derivative| / 6 = 1 (from x0^3)
    if (previous > 0.0) {
      EXPECT_NEAR(previous / error, 4.0, 0.1);  // O(h^2): halving h divides the error by 4
    }
    previous = error;
  }
}

// p_WTip = X_WE * p_ET: analytic Jacobian in both frames
TEST(FiniteDifferenceJacobian, PoseJacobianOfTheTipPositionInBothFrames) {
  Eigen::Isometry3d X_WE = Eigen::Isometry3d::Identity();
  X_WE.linear() = ExpSO3(Eigen::Vector3d(0.4, -0.3, 1.1));
  X_WE.translation() = Eigen::Vector3d(0.1, 0.2, 0.5);
  const Eigen::Vector3d p_ET(0.0, 0.01, 0.15);
  auto tip = [&](const Eigen::Isometry3d& X) -> Eigen::VectorXd { return X * p_ET; };
  const Eigen::Matrix3d R = X_WE.linear();
  Vector6d steps;
  steps << 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4;
  Eigen::MatrixXd J;
  FiniteDifferenceStatus status =
      CalcPoseJacobian(X_WE, steps, PoseIncrementFrame::kWorldAligned, tip, &J);
  EXPECT_EQ(status.evaluations, 12);
  Eigen::Matrix<double, 3, 6> expected;
  expected << Eigen::Matrix3d::Identity(), -Skew(R * p_ET);
  EXPECT_LT((J - expected).cwiseAbs().maxCoeff(), 1e-8);
  CalcPoseJacobian(X_WE, steps, PoseIncrementFrame::kBody, tip, &J);
  expected << R, -R * Skew(p_ET);
  EXPECT_LT((J - expected).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(FiniteDifferenceJacobian, PosePerturbationsAreOneDofEach) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = ExpSO3(Eigen::Vector3d(-0.2, 0.5, 0.1));
  X.translation() = Eigen::Vector3d(0.3, -0.1, 0.9);
  Vector6d steps;
  steps << 1e-3, 2e-3, 3e-3, 1e-2, 2e-2, 3e-2;
  for (PoseIncrementFrame frame : {PoseIncrementFrame::kWorldAligned, PoseIncrementFrame::kBody}) {
    const auto poses = MakePosePerturbations(X, steps, frame);
    for (int j = 0; j < 6; ++j) {
      for (int sign : {0, 1}) {
        Vector6d expected = Vector6d::Zero();
        expected[j] = sign == 0 ? steps[j] : -steps[j];
        const Vector6d d = CalcPoseDifference(poses[2 * j + sign], X, frame);
        EXPECT_LT((d - expected).cwiseAbs().maxCoeff(), 1e-12) << "dof " << j;
      }
    }
  }
  const Vector7d q = Vector7d::LinSpaced(0.1, 0.7);
  const Vector7d qs = Vector7d::Constant(1e-3);
  const auto joints = MakeJointPerturbations(q, qs);
  for (int j = 0; j < 7; ++j) {
    EXPECT_LT((joints[2 * j] - q - qs[j] * Vector7d::Unit(j)).norm(), kRoundoff);
    EXPECT_LT((joints[2 * j + 1] - q + qs[j] * Vector7d::Unit(j)).norm(), kRoundoff);
  }
}

TEST(FiniteDifferenceJacobian, AssembledFromSamplesEqualsDirect) {
  std::mt19937_64 rng(42);
  const Eigen::MatrixXd A = RandomMatrix(5, 7, rng);
  auto e = [&](const Vector7d& q) -> Eigen::VectorXd { return A * q.array().sin().matrix(); };
  const Vector7d q = Vector7d::LinSpaced(-0.5, 0.5);
  const Vector7d steps = Vector7d::Constant(1e-4);
  Eigen::MatrixXd J_direct, J_assembled;
  const FiniteDifferenceStatus s1 = CalcJointJacobian(q, steps, e, &J_direct);
  EXPECT_EQ(s1.evaluations, 14);
  std::vector<Eigen::VectorXd> samples;
  for (const Vector7d& qp : MakeJointPerturbations(q, steps)) samples.push_back(e(qp));
  AssembleCentralDifferenceJacobian(samples, Eigen::VectorXd(steps), &J_assembled);
  EXPECT_LT((J_direct - J_assembled).cwiseAbs().maxCoeff(), kRoundoff);
  const Eigen::MatrixXd analytic = A * q.array().cos().matrix().asDiagonal();
  EXPECT_LT((J_direct - analytic).cwiseAbs().maxCoeff(), 1e-8);
}

class CountingEvaluator : public ObjectiveEvaluator {
 public:
  Eigen::VectorXd Evaluate(const Eigen::VectorXd& delta) const override {
    ++calls_;
    return Eigen::Vector2d(2 * delta[0] - delta[1], 3 * delta[1]);
  }
  mutable int calls_ = 0;  // only for the test; the objectives themselves have no state
};

TEST(FiniteDifferenceJacobian, EvaluatorInterfaceAndFaults) {
  CountingEvaluator evaluator;
  Eigen::MatrixXd J;
  CalcCentralDifferenceJacobian(evaluator, Eigen::Vector2d(1e-3, 1e-3), &J);
  EXPECT_EQ(evaluator.calls_, 4);
  EXPECT_LT((J - (Eigen::Matrix2d() << 2, -1, 0, 3).finished()).cwiseAbs().maxCoeff(), 1e-12);
  // a diverged evaluation is flagged, not hidden
  auto nan_at_dof_1 = [](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    return Eigen::VectorXd::Constant(2, d[1] > 0 ? std::nan("") : 1.0);
  };
  EXPECT_FALSE(CalcCentralDifferenceJacobian(nan_at_dof_1, Eigen::Vector2d(1, 1), &J).all_finite);
  // inconsistent row counts and bad steps are input errors
  auto ragged = [](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    return Eigen::VectorXd::Zero(d[0] > 0 ? 3 : 2);
  };
  EXPECT_THROW(CalcCentralDifferenceJacobian(ragged, Eigen::Vector2d(1, 1), &J), InputError);
  try {
    CalcCentralDifferenceJacobian(nan_at_dof_1, Eigen::Vector2d(1, 0), &J);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "finite-difference steps[1] must be > 0 and finite, got 0");
  }
  std::vector<Eigen::VectorXd> three(3, Eigen::VectorXd::Zero(2));
  EXPECT_THROW(AssembleCentralDifferenceJacobian(three, Eigen::Vector2d(1, 1), &J), InputError);
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.linear()(0, 0) = 2.0;
  EXPECT_THROW(MakePosePerturbations(bad, Vector6d::Constant(1e-3), PoseIncrementFrame::kBody),
               InputError);
}

}  // namespace
}  // namespace nsim
