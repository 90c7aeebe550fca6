#include "common/constraints/dense_linear_body.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <string>

#include "common/core/error.h"
#include "tests/constraints/test_helpers.h"

namespace nsim {
namespace {

using testing::MakeChainConfig;
using testing::MakeParticleConfig;

constexpr double kRelative = 1e-12;  // relative round-off on small dense systems

TEST(DenseLinearBodyTest, FreeFallMatchesImplicitEulerClosedForm) {
  const double h = 0.01;
  const Eigen::Vector3d g(0.0, 1.0, -9.81), x0(0.1, 0.2, 0.3);
  DenseLinearBody body(MakeParticleConfig(x0, 2.0, h, g));
  const int steps = 25;
  for (int k = 0; k < steps; ++k) body.SolveFreeMotion();
  // v_k = k h g, x_k = x0 + h^2 g k (k + 1) / 2
  EXPECT_LE((body.velocities().col(0) - steps * h * g).norm(), kRelative * steps * h * g.norm());
  const Eigen::Vector3d x = x0 + h * h * g * steps * (steps + 1) / 2.0;
  EXPECT_LE((body.positions().col(0) - x).norm(), kRelative * x.norm());
  EXPECT_LE((body.free_positions() - body.positions()).norm(), 0.0);
}

TEST(DenseLinearBodyTest, ComplianceIsHSquaredAInverseAndVersioned) {
  const double h = 0.02;
  DenseLinearBodyConfig c =
      MakeChainConfig(3, 0.1, 0.02, 40.0, h, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  c.rayleigh_mass = 0.5;
  c.rayleigh_stiffness = 0.01;
  DenseLinearBody body(c);
  // A = (1 + h alpha) M + (h beta + h^2) K
  Eigen::MatrixXd A = (h * 0.01 + h * h) * c.stiffness;
  A.diagonal().array() += (1.0 + h * 0.5) * 0.1;
  EXPECT_LE((body.system_matrix() - A).norm(), kRelative * A.norm());
  Eigen::SparseMatrix<double> f(9, 2);
  f.insert(4, 0) = 1.0;
  f.insert(0, 1) = 0.5;
  f.insert(8, 1) = -0.5;
  Eigen::MatrixXd dx;
  body.ApplyCompliance(f, dx);
  const Eigen::MatrixXd expected = h * h * A.inverse() * Eigen::MatrixXd(f);
  EXPECT_LE((dx - expected).norm(), kRelative * expected.norm());
  const std::uint64_t v0 = body.compliance_version();
  body.SolveFreeMotion();
  EXPECT_EQ(body.compliance_version(), v0);
  body.set_time_step(0.01);
  EXPECT_NE(body.compliance_version(), v0);
}

TEST(DenseLinearBodyTest, SpringsConserveMomentumAndDissipateEnergy) {
  DenseLinearBody body(
      MakeChainConfig(4, 0.1, 0.02, 40.0, 0.01, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
  Eigen::Matrix3Xd v = Eigen::Matrix3Xd::Zero(3, 4);
  v.col(0) << 0.3, 0.0, 0.1;
  v.col(3) << -0.1, 0.2, 0.0;
  body.set_velocities(v);
  const Eigen::Vector3d p0 = body.CalcMomentum();
  for (int k = 0; k < 100; ++k) body.SolveFreeMotion();
  EXPECT_LE((body.CalcMomentum() - p0).norm(), kRelative * p0.norm());
  // the correction adds dx to x and dx / h to v
  const Eigen::Matrix3Xd x = body.positions(), vb = body.velocities();
  const Eigen::Matrix3Xd dx = Eigen::Matrix3Xd::Constant(3, 4, 1e-3);
  body.ApplyCorrection(dx);
  EXPECT_LE((body.positions() - x - dx).norm(), 1e-15);
  EXPECT_LE((body.velocities() - vb - dx / 0.01).norm(), 1e-12);
}

TEST(DenseLinearBodyTest, RejectsBadInput) {
  auto expect = [](const DenseLinearBodyConfig& c, const std::string& fragment) {
    try {
      DenseLinearBody body(c);
      FAIL() << "expected InputError containing " << fragment;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  DenseLinearBodyConfig ok =
      MakeParticleConfig(Eigen::Matrix3Xd::Zero(3, 2), 1.0, 0.01, Eigen::Vector3d::Zero());
  DenseLinearBodyConfig c = ok;
  c.masses = Eigen::VectorXd::Ones(3);
  expect(c, "expected 2 masses, got 3");
  c = ok;
  c.masses[1] = 0.0;
  expect(c, "masses must be > 0 (kg), got 0");
  c = ok;
  c.time_step = -0.01;
  expect(c, "time_step must be > 0 (s), got -0.01");
  c = ok;
  c.stiffness = Eigen::MatrixXd::Identity(5, 5);
  expect(c, "expected a 6 x 6 stiffness, got 5 x 5");
  c = ok;
  c.stiffness = Eigen::MatrixXd::Identity(6, 6);
  c.stiffness(0, 1) = 1.0;
  expect(c, "symmetric");
  c = ok;
  c.stiffness = -1e6 * Eigen::MatrixXd::Identity(6, 6);
  expect(c, "not positive definite");
  c = ok;
  c.rayleigh_mass = -1.0;
  expect(c, "Rayleigh coefficients must be >= 0");
}

}  // namespace
}  // namespace nsim
