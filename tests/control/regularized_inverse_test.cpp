#include "common/control/regularized_inverse.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kAgreement = 1e-10;  // relative, two ways to the same matrix (cond <= 1e3)
// relative accuracy of a singular value s = r = 1e-6 next to s_max = 3: eps s_max / s ~ 1e-9
constexpr double kBoundSlack = 1e-8;

Eigen::MatrixXd RandomOrthogonal(int n, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n * n; ++i) A.data()[i] = g(rng);
  return Eigen::HouseholderQR<Eigen::MatrixXd>(A).householderQ();
}

// J (m x n) with the given singular values (min(m, n) of them)
Eigen::MatrixXd MakeJacobian(int m, int n, const Eigen::VectorXd& s, std::mt19937_64& rng) {
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(m, n);
  for (int i = 0; i < s.size(); ++i) S(i, i) = s[i];
  return RandomOrthogonal(m, rng) * S * RandomOrthogonal(n, rng).transpose();
}

double Norm2(const Eigen::MatrixXd& A) {
  return Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues()[0];
}

double RelativeError(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) {
  return (A - B).norm() / B.norm();
}

struct Shape {
  int m, n;
};
constexpr Shape kShapes[] = {{6, 6}, {5, 7}, {4, 6}, {6, 7}, {5, 6}, {7, 6}};

// all nonzero s^2 > r: the clamped reading is exactly Moore-Penrose, also for wide J whose
// J^T J has a null space (those eigenvalues are raised to r, but J^T has no component there)
TEST(TikhonovPseudoInverse, EqualsMoorePenroseWhenWellConditioned) {
  std::mt19937_64 rng(31);
  const double r = 1e-4;
  for (const Shape& shape : kShapes) {
    const int k = std::min(shape.m, shape.n);
    Eigen::VectorXd s(k);
    for (int i = 0; i < k; ++i) s[i] = 0.02 + 2.0 * i;  // s^2 >= 4e-4 > r
    const Eigen::MatrixXd J = MakeJacobian(shape.m, shape.n, s, rng);
    const Eigen::MatrixXd pinv = J.completeOrthogonalDecomposition().pseudoInverse();
    Eigen::MatrixXd J_r;
    CalcTikhonovPseudoInverse(J, r, &J_r);
    ASSERT_EQ(J_r.rows(), shape.n);
    ASSERT_EQ(J_r.cols(), shape.m);
    EXPECT_LT(RelativeError(J_r, pinv), kAgreement) << shape.m << "x" << shape.n;
    // Penrose conditions
    EXPECT_LT(RelativeError(J * J_r * J, J), kAgreement);
    EXPECT_LT(RelativeError(J_r * J * J_r, J_r), kAgreement);
    // the literal reading is J^+ / (1 + r) there
    Eigen::MatrixXd J_lit;
    CalcTikhonovPseudoInverse(J, r, &J_lit, TikhonovForm::kLiteralAdditive);
    EXPECT_LT(RelativeError(J_lit, pinv / (1.0 + r)), kAgreement) << shape.m << "x" << shape.n;
  }
}

TEST(TikhonovPseudoInverse, IsBoundedWhenSingular) {
  std::mt19937_64 rng(32);
  for (double r : {1e-6, 1e-3, 0.1}) {
    for (const Shape& shape : kShapes) {
      const int k = std::min(shape.m, shape.n);
      // singular values: 0, tiny, sqrt(r) (where the clamped bound is attained), r (where the
      // literal one is), and large
      Eigen::VectorXd s = Eigen::VectorXd::Zero(k);
      s[1] = 1e-9;
      s[2] = std::sqrt(r);
      s[3] = r;
      if (k > 4) s[4] = 3.0;
      const Eigen::MatrixXd J = MakeJacobian(shape.m, shape.n, s, rng);
      for (TikhonovForm form : {TikhonovForm::kClampedSpectrum, TikhonovForm::kLiteralAdditive}) {
        Eigen::MatrixXd J_r;
        CalcTikhonovPseudoInverse(J, r, &J_r, form);
        ASSERT_TRUE(J_r.allFinite());
        const double bound = CalcTikhonovNormBound(r, form);
        EXPECT_LE(Norm2(J_r), bound * (1 + kBoundSlack)) << "r " << r;
        // the bound is attained (to the conditioning of the construction)
        EXPECT_GE(Norm2(J_r), bound * (1 - 1e-6)) << "r " << r;
      }
    }
  }
  EXPECT_DOUBLE_EQ(CalcTikhonovNormBound(1e-4, TikhonovForm::kClampedSpectrum), 100.0);
  EXPECT_DOUBLE_EQ(CalcTikhonovNormBound(1e-4, TikhonovForm::kLiteralAdditive), 5000.0);
}

TEST(TikhonovPseudoInverse, ActsOnlyOnTheSpectrumBelowR) {
  // J = diag(2, 1e-3, 0): d = 4, 1e-6, 0; with r = 1e-2 the gains are 1/2, 1e-3/1e-2, 0
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3, 3);
  J(0, 0) = 2.0;
  J(1, 1) = 1e-3;
  Eigen::MatrixXd J_r;
  CalcTikhonovPseudoInverse(J, 1e-2, &J_r);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(3, 3);
  expected(0, 0) = 0.5;
  expected(1, 1) = 0.1;
  EXPECT_LT((J_r - expected).cwiseAbs().maxCoeff(), 1e-14);
  // literal: 2 / (4 + 0.04) and 1e-3 / (1e-6 + 1e-4)
  CalcTikhonovPseudoInverse(J, 1e-2, &J_r, TikhonovForm::kLiteralAdditive);
  EXPECT_NEAR(J_r(0, 0), 2.0 / 4.04, 1e-14);
  EXPECT_NEAR(J_r(1, 1), 1e-3 / 1.01e-4, 1e-10);
  EXPECT_NEAR(J_r(2, 2), 0.0, 1e-14);
}

TEST(DampedLeastSquares, MatchesTheDefinitionAndIsBiasedWhereTikhonovIsNot) {
  std::mt19937_64 rng(33);
  const double lambda = 0.05;
  for (const Shape& shape : kShapes) {
    const int k = std::min(shape.m, shape.n);
    Eigen::VectorXd s(k);
    for (int i = 0; i < k; ++i) s[i] = 0.1 + i;
    const Eigen::MatrixXd J = MakeJacobian(shape.m, shape.n, s, rng);
    Eigen::MatrixXd J_dls;
    CalcDampedLeastSquaresInverse(J, lambda, &J_dls);
    const Eigen::MatrixXd definition =
        J.transpose() *
        (J * J.transpose() + lambda * lambda * Eigen::MatrixXd::Identity(shape.m, shape.m))
            .inverse();
    EXPECT_LT(RelativeError(J_dls, definition), kAgreement);
    EXPECT_LE(Norm2(J_dls), 1.0 / (2 * lambda) * (1 + 1e-12));
    // on the smallest direction DLS gives s / (s^2 + lambda^2), 20 % below 1 / s here, while the
    // clamped Tikhonov with r = lambda^2 < s^2 gives 1 / s exactly
    Eigen::MatrixXd J_r;
    CalcTikhonovPseudoInverse(J, lambda * lambda, &J_r);
    const Eigen::MatrixXd pinv = J.completeOrthogonalDecomposition().pseudoInverse();
    EXPECT_LT(RelativeError(J_r, pinv), kAgreement);
    EXPECT_GT(RelativeError(J_dls, pinv), 0.01);
  }
}

TEST(TikhonovPseudoInverse, BadInput) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Identity(3, 3);
  Eigen::MatrixXd out;
  EXPECT_THROW(CalcTikhonovPseudoInverse(J, 0.0, &out), InputError);
  EXPECT_THROW(CalcTikhonovPseudoInverse(J, std::nan(""), &out), InputError);
  EXPECT_THROW(CalcDampedLeastSquaresInverse(J, -1.0, &out), InputError);
  J(1, 2) = std::nan("");
  EXPECT_THROW(CalcTikhonovPseudoInverse(J, 1e-3, &out), InputError);
  EXPECT_THROW(CalcTikhonovPseudoInverse(Eigen::MatrixXd::Identity(13, 13), 1e-3, &out),
               InputError);
  try {
    CalcTikhonovPseudoInverse(Eigen::MatrixXd(0, 6), 1e-3, &out);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "Tikhonov pseudo-inverse: expected a Jacobian of 1..32 rows and 1..12 columns, "
                 "got 0 x 6");
  }
}

}  // namespace
}  // namespace nsim
