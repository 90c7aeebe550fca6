#include "common/fem/corotational.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "common/core/error.h"
#include "common/mesh/tet_mesh.h"

namespace nsim {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
// rotations and orthogonality to a few hundred ulps
constexpr double kRotationTol = 1e-13;
// central differences: truncation O(d^2) plus round-off O(eps / d); with d = 1e-6 L the error
// relative to the derivative's scale is ~1e-8; allow 1e-6 (sqrt(eps) scale)
constexpr double kFdStep = 1e-6;
constexpr double kFdTol = 1e-6;

Matrix34d IrregularTet() {
  Matrix34d X;
  X << 0.0, 1.0, 0.2, 0.1,  //
      0.0, 0.1, 0.9, 0.3,   //
      0.0, 0.05, 0.2, 1.1;
  return 0.01 * X;  // 1 cm tet
}

Eigen::Matrix3d RandomRotation(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  return Eigen::AngleAxisd(max_angle * std::abs(u(rng)), axis.normalized()).toRotationMatrix();
}

LameParameters Liver() { return CalcLameParameters(5500.0, 0.45); }

TEST(CorotationalTest, RestShapeGradients) {
  const Matrix34d X = IrregularTet();
  const TetRestShape rest = CalcTetRestShape(X);
  EXPECT_NEAR(rest.volume, SignedTetVolume(X.col(0), X.col(1), X.col(2), X.col(3)), 1e-15 * 1e-6);
  // partition of unity and linear completeness: sum g_a = 0, sum X_a g_a^T = I
  EXPECT_LT(rest.grad_n.rowwise().sum().norm(), 1e3 * kEps * rest.grad_n.norm());
  EXPECT_TRUE((X * rest.grad_n.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-13));
}

TEST(CorotationalTest, DegenerateOrInvertedRestShapeIsInputError) {
  Matrix34d flat = IrregularTet();
  flat.row(2).setZero();
  EXPECT_THROW(CalcTetRestShape(flat), InputError);
  Matrix34d inverted = IrregularTet();
  inverted.col(2).swap(inverted.col(3));
  EXPECT_THROW(CalcTetRestShape(inverted), InputError);
}

TEST(CorotationalTest, PolarRotationRecoversRotationOfStretch) {
  // R S with S symmetric positive definite: the polar factor is R, to the stated precision
  // kPolarStepTolerance^2 at every stretch, down to those stopped after one Newton step (the
  // error is about half that bound at worst: 4.7e-9 over these draws)
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double bound = kPolarStepTolerance * kPolarStepTolerance;
  for (double stretch : {0.4, 1e-2, 1e-3, 2e-4, 1e-4, 5e-5, 1e-6}) {
    double worst = 0.0;
    for (int trial = 0; trial < 200; ++trial) {
      const Eigen::Matrix3d R = RandomRotation(rng, M_PI);
      Eigen::Matrix3d B;
      for (int i = 0; i < 9; ++i) B(i) = u(rng);
      const Eigen::Matrix3d S = Eigen::Matrix3d::Identity() + 0.5 * stretch * (B + B.transpose());
      bool used_svd = true;
      const Eigen::Matrix3d Rp = CalcPolarRotation(R * S, &used_svd);
      EXPECT_FALSE(used_svd);
      worst = std::max(worst, (Rp - R).norm());
    }
    EXPECT_LT(worst, bound) << "stretch " << stretch;
  }
}

TEST(CorotationalTest, PolarRotationOfInvertedAndDegenerateIsProperRotation) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d R = RandomRotation(rng, M_PI);
    // inverted: one axis reflected, and a flattened one (det 0)
    for (const Eigen::Vector3d& diag : {Eigen::Vector3d(1.2, 0.9, -0.3), Eigen::Vector3d(1.0, 1.0, 0.0)}) {
      bool used_svd = false;
      const Eigen::Matrix3d Rp = CalcPolarRotation(R * diag.asDiagonal(), &used_svd);
      EXPECT_TRUE(used_svd);
      EXPECT_NEAR(Rp.determinant(), 1.0, kRotationTol);
      EXPECT_LT((Rp.transpose() * Rp - Eigen::Matrix3d::Identity()).norm(), kRotationTol);
      // Irving et al.: the smallest principal axis is flipped, the others kept, so R = the
      // rotation itself here (diag's small entry is along the third axis)
      EXPECT_LT((Rp - R).norm(), 1e-12);
    }
  }
}

TEST(CorotationalTest, PolarRotationsInBlocksEqualOneByOne) {
  // 23 matrices (blocks of kTetLanes and a partial one): stretches from 1e-6 to 0.4 (one to
  // six Newton iterations, so lanes of a block stop at different iterations), inverted and
  // flattened ones (the SVD branch) among them; each the rotation of its own call
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double stretches[] = {0.4, 1e-2, 1e-6, 3e-2, 1e-4, 0.1, 2e-3};
  std::vector<Eigen::Matrix3d> F(23), R(23);
  for (int k = 0; k < 23; ++k) {
    Eigen::Matrix3d B;
    for (int i = 0; i < 9; ++i) B(i) = u(rng);
    const Eigen::Matrix3d S =
        Eigen::Matrix3d::Identity() + 0.5 * stretches[k % 7] * (B + B.transpose());
    F[k] = RandomRotation(rng, M_PI) * S;
    if (k % 5 == 3) F[k].col(2) *= -0.5;  // inverted
    if (k == 9) F[k].col(1).setZero();    // flattened
  }
  bool used_svd[23];
  CalcPolarRotations(F.data(), R.data(), used_svd, 23);
  for (int k = 0; k < 23; ++k) {
    bool svd = false;
    const Eigen::Matrix3d one = CalcPolarRotation(F[k], &svd);
    EXPECT_EQ(used_svd[k], svd) << k;
    EXPECT_EQ(used_svd[k], k % 5 == 3 || k == 9) << k;
    EXPECT_LT((R[k] - one).norm(), 1e-14) << k;
    EXPECT_NEAR(R[k].determinant(), 1.0, kPolarStepTolerance * kPolarStepTolerance) << k;
  }
}

TEST(CorotationalTest, RestStiffnessEqualsVoigtBtDB) {
  // independent reference: K = V B^T D B with the 6 x 12 strain-displacement matrix in Voigt
  // notation (engineering shear strains) and the isotropic 6 x 6 elasticity matrix
  const TetRestShape rest = CalcTetRestShape(IrregularTet());
  const LameParameters lame = Liver();
  Eigen::Matrix<double, 6, 12> B = Eigen::Matrix<double, 6, 12>::Zero();
  for (int a = 0; a < 4; ++a) {
    const Eigen::Vector3d g = rest.grad_n.col(a);
    B(0, 3 * a) = g.x();
    B(1, 3 * a + 1) = g.y();
    B(2, 3 * a + 2) = g.z();
    B(3, 3 * a) = g.y(), B(3, 3 * a + 1) = g.x();
    B(4, 3 * a + 1) = g.z(), B(4, 3 * a + 2) = g.y();
    B(5, 3 * a) = g.z(), B(5, 3 * a + 2) = g.x();
  }
  Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
  D.topLeftCorner<3, 3>().setConstant(lame.lambda);
  D.topLeftCorner<3, 3>().diagonal().array() += 2.0 * lame.mu;
  D.bottomRightCorner<3, 3>().diagonal().setConstant(lame.mu);
  const Matrix12d K_ref = rest.volume * B.transpose() * D * B;
  const Matrix12d K = CalcCorotatedStiffness(rest, lame, Eigen::Matrix3d::Identity());
  EXPECT_LT((K - K_ref).norm(), 1e-13 * K_ref.norm());
  // rotated: R K R^T block-wise
  std::mt19937 rng(3);
  const Eigen::Matrix3d R = RandomRotation(rng, 2.0);
  Matrix12d Rb = Matrix12d::Zero();
  for (int a = 0; a < 4; ++a) Rb.block<3, 3>(3 * a, 3 * a) = R;
  EXPECT_LT((CalcCorotatedStiffness(rest, lame, R) - Rb * K_ref * Rb.transpose()).norm(),
            1e-13 * K_ref.norm());
}

TEST(CorotationalTest, MatrixFreeProductEqualsDenseStiffness) {
  const TetRestShape rest = CalcTetRestShape(IrregularTet());
  std::mt19937 rng(5);
  const Eigen::Matrix3d R = RandomRotation(rng, 3.0);
  const Matrix34d p = Matrix34d::Random();
  const Matrix12d K = CalcCorotatedStiffness(rest, Liver(), R);
  const Eigen::Matrix<double, 12, 1> y =
      K * Eigen::Map<const Eigen::Matrix<double, 12, 1>>(p.data());
  const Matrix34d y_free = ApplyCorotatedStiffness(rest, Liver(), R, p);
  EXPECT_LT((Eigen::Map<const Eigen::Matrix<double, 12, 1>>(y_free.data()) - y).norm(),
            1e-13 * K.norm() * p.norm());
}

// the right-hand side's fused kernel against the force and the product it replaces, for
// stretched, rotated elements away from the origin and arbitrary velocities (h and c of the
// patient's liver): to round-off with an exact rotation (F = R S, S symmetric positive
// definite, so R is F's polar factor), and to the polar decomposition's stated precision with
// CalcPolarRotation's R (the two forms use R^T R = I, which that R meets to ~1e-8)
TEST(CorotationalTest, StepLoadIsForceAndStiffnessProductInOne) {
  const TetRestShape rest = CalcTetRestShape(IrregularTet());
  const LameParameters lame = Liver();
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double h = 0.02, c = 0.02 * 0.01 + 0.02 * 0.02;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    for (int i = 0; i < 3; ++i) {
      S(i, i) += 0.2 * u(rng);
      for (int j = i + 1; j < 3; ++j) S(i, j) = S(j, i) = 0.1 * u(rng);
    }
    const Eigen::Matrix3d R = RandomRotation(rng, M_PI);
    Matrix34d x = R * S * IrregularTet();
    x.colwise() += 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));  // translations must cancel
    const Matrix34d w = 0.05 * Matrix34d::Random();
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, x);
    const Eigen::Matrix3d rotations[2] = {R, CalcPolarRotation(F)};
    for (int k = 0; k < 2; ++k) {
      const Eigen::Matrix3d& Rk = rotations[k];
      const Matrix34d force = h * CalcCorotatedForce(rest, lame, Rk, F);
      const Matrix34d product = c * ApplyCorotatedStiffness(rest, lame, Rk, w);
      const Matrix34d fused = CalcCorotatedStepLoad(rest, lame, Rk * rest.grad_n, x, w, h, c);
      const double tolerance = k == 0 ? 1e-12 : 1e-7;
      EXPECT_LT((fused - (force - product)).norm(), tolerance * (force.norm() + product.norm()))
          << trial;
    }
  }
  // a rigid motion at rest velocity loads nothing
  const Eigen::Matrix3d R = RandomRotation(rng, 2.0);
  const Matrix34d x = R * IrregularTet();
  EXPECT_LT(CalcCorotatedStepLoad(rest, lame, R * rest.grad_n, x, Matrix34d::Zero(), h, c).norm(),
            1e-12 * h * lame.mu * rest.volume * rest.grad_n.norm());
}

// forces of an element moved rigidly: the co-rotational element gives zero, the small-strain
// linear one (R = I) a spurious ("ghost") force growing with the angle
TEST(CorotationalTest, RigidMotionGivesNoForceAndLinearFemGhostForces) {
  const Matrix34d X = IrregularTet();
  const TetRestShape rest = CalcTetRestShape(X);
  const LameParameters lame = Liver();
  // force scale of a unit strain: E V / L
  const double force_scale = 5500.0 * rest.volume / 0.01;
  std::mt19937 rng(13);
  for (double angle : {0.1, 0.5, M_PI / 2, 3.0}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    const Matrix34d x = (R * X).colwise() + Eigen::Vector3d(0.3, -1.0, 2.0);
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, x);
    const Eigen::Matrix3d Rp = CalcPolarRotation(F);
    EXPECT_LT(CalcCorotatedForce(rest, lame, Rp, F).norm(), 1e-12 * force_scale) << angle;
    EXPECT_LT(CalcCorotatedEnergy(rest, lame, Rp, F), 1e-24 * force_scale * 0.01) << angle;
    // linear FEM: ghost force of order (1 - cos angle) E V / L
    const double ghost = CalcCorotatedForce(rest, lame, Eigen::Matrix3d::Identity(), F).norm();
    EXPECT_GT(ghost, 0.1 * (1.0 - std::cos(angle)) * force_scale) << angle;
    EXPECT_GT(CalcCorotatedEnergy(rest, lame, Eigen::Matrix3d::Identity(), F), 0.0);
  }
}

// the co-rotational force is the exact negative gradient of the co-rotated strain energy
TEST(CorotationalTest, ForceIsMinusFiniteDifferenceGradientOfEnergy) {
  const Matrix34d X = IrregularTet();
  const TetRestShape rest = CalcTetRestShape(X);
  const LameParameters lame = Liver();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  auto energy = [&](const Matrix34d& x) {
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, x);
    return CalcCorotatedEnergy(rest, lame, CalcPolarRotation(F), F);
  };
  for (int trial = 0; trial < 10; ++trial) {
    Matrix34d x = RandomRotation(rng, 2.5) * X;
    for (int i = 0; i < 12; ++i) x(i) += 0.01 * u(rng);  // strains up to ~30 %
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, x);
    const Matrix34d f = CalcCorotatedForce(rest, lame, CalcPolarRotation(F), F);
    Matrix34d f_fd;
    const double d = kFdStep * 0.01;
    for (int i = 0; i < 12; ++i) {
      Matrix34d xp = x, xm = x;
      xp(i) += d;
      xm(i) -= d;
      f_fd(i) = -(energy(xp) - energy(xm)) / (2 * d);
    }
    EXPECT_LT((f - f_fd).norm(), kFdTol * f.norm()) << "trial " << trial;
  }
}

// R K_e R^T is the exact derivative of the co-rotated force at zero strain (any rotation and
// translation); under strain, it omits the rotation-derivative terms (the usual co-rotational
// linearization, Müller & Gross 2004), an O(strain) difference, checked to shrink linearly
TEST(CorotationalTest, StiffnessEqualsFiniteDifferenceOfForce) {
  const Matrix34d X = IrregularTet();
  const TetRestShape rest = CalcTetRestShape(X);
  const LameParameters lame = Liver();
  auto fd_jacobian = [&](const Matrix34d& x) {
    Matrix12d J;
    const double d = kFdStep * 0.01;
    for (int i = 0; i < 12; ++i) {
      Matrix34d xp = x, xm = x;
      xp(i) += d;
      xm(i) -= d;
      const Eigen::Matrix3d Fp = CalcDeformationGradient(rest, xp);
      const Eigen::Matrix3d Fm = CalcDeformationGradient(rest, xm);
      const Matrix34d df = CalcCorotatedForce(rest, lame, CalcPolarRotation(Fp), Fp) -
                           CalcCorotatedForce(rest, lame, CalcPolarRotation(Fm), Fm);
      J.col(i) = -Eigen::Map<const Eigen::Matrix<double, 12, 1>>(df.data()) / (2 * d);
    }
    return J;
  };
  std::mt19937 rng(19);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Matrix3d R = RandomRotation(rng, 3.0);
    const Matrix34d x = (R * X).colwise() + Eigen::Vector3d(0.1, 0.2, -0.3);
    const Matrix12d K = CalcCorotatedStiffness(rest, lame, R);
    EXPECT_LT((fd_jacobian(x) - K).norm(), kFdTol * K.norm()) << "trial " << trial;
  }
  // strained: difference / ||K|| of order the strain, halving with the strain
  const Eigen::Matrix3d R = RandomRotation(rng, 1.0);
  Matrix34d direction = Matrix34d::Random() * 0.01;
  double previous = 0.0;
  for (double strain : {0.04, 0.02, 0.01}) {
    const Matrix34d x = R * (X + strain * direction);
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, x);
    const Matrix12d K = CalcCorotatedStiffness(rest, lame, CalcPolarRotation(F));
    const double relative = (fd_jacobian(x) - K).norm() / K.norm();
    EXPECT_LT(relative, 10.0 * strain) << strain;
    if (previous > 0) {
      EXPECT_GT(previous / relative, 1.6) << strain;
      EXPECT_LT(previous / relative, 2.4) << strain;
    }
    previous = relative;
  }
}

}  // namespace
}  // namespace nsim
