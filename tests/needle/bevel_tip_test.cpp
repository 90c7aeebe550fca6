#include "common/needle/bevel_tip.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

// loads are O(1 N) and O(1 mN m): relative round-off bound
constexpr double kRelTol = 1e-12;

TEST(BevelTipTest, LoadsMatchEquations21To23ByHand) {
  // thesis table 5.3 parameters, evaluated independently term by term
  BevelConfig c;
  c.diameter = 1.2e-3;
  c.bevel_angle = 0.2617;
  c.beta_over_alpha = 0.9;
  c.tissue_stiffness = 150e3;
  const double alpha = 0.2617, beta = 0.9 * 0.2617, d = 1.2e-3, kt = 150e3;
  const double a = d / std::tan(alpha);
  const double b = d / std::sin(alpha);
  const double e = d - a * std::tan(beta) - (b / 3.0) * std::sin(alpha);
  const double q = kt * a * a / 2.0 * std::tan(beta) -
                   kt * b * b / 2.0 * std::cos(alpha) * std::tan(alpha - beta);
  const double m =
      kt * b * b / 2.0 *
          (b / 3.0 * std::pow(std::cos(alpha), 2) - e * std::sin(alpha)) * std::tan(alpha - beta) -
      kt * std::pow(a, 3) / 6.0 * std::tan(beta);
  const double p = -kt * b * b / 2.0 * std::sin(alpha) * std::tan(alpha - beta);

  const BevelLoads l = CalcBevelLoads(c);
  EXPECT_NEAR(l.a, a, kRelTol * a);
  EXPECT_NEAR(l.b, b, kRelTol * b);
  EXPECT_NEAR(l.e, e, kRelTol * std::abs(e));
  EXPECT_NEAR(l.q, q, kRelTol * std::abs(q));
  EXPECT_NEAR(l.m, m, kRelTol * std::abs(m));
  EXPECT_NEAR(l.p_bevel, p, kRelTol * std::abs(p));
  // table 5.3 reports |M| = 0.48 mN m for these parameters (two digits)
  EXPECT_NEAR(std::abs(l.m), 0.48e-3, 0.005e-3);
  EXPECT_GT(l.q, 0.0);
  EXPECT_LT(l.m, 0.0);
}

TEST(BevelTipTest, FullCutAngleHasNoAlphaMinusBetaTerms) {
  // beta = alpha: Q = K_T a^2/2 tan(alpha), M = -K_T a^3/6 tan(alpha), P_bevel = 0
  BevelConfig c;
  c.beta_over_alpha = 1.0;
  const BevelLoads l = CalcBevelLoads(c);
  const double a = c.diameter / std::tan(c.bevel_angle);
  EXPECT_NEAR(l.q, c.tissue_stiffness * a * a / 2 * std::tan(c.bevel_angle), kRelTol * l.q);
  EXPECT_NEAR(l.m, -c.tissue_stiffness * a * a * a / 6 * std::tan(c.bevel_angle),
              kRelTol * std::abs(l.m));
  EXPECT_NEAR(l.p_bevel, 0.0, 1e-18);
}

TEST(BevelTipTest, FrameAndLoadDirections) {
  BevelConfig c;
  c.enabled = true;
  const BevelLoads l = CalcBevelLoads(c);
  const Eigen::Matrix3d R_WB = CalcBevelFrame(Eigen::Matrix3d::Identity(), M_PI / 2);
  // rolling by 90 degrees about z turns the bevel side y_B from +y to -x
  EXPECT_TRUE(R_WB.col(1).isApprox(Eigen::Vector3d(-1, 0, 0), 1e-12));
  Eigen::Vector3d f, tau;
  CalcBevelTipLoad(c, l, R_WB, f, tau);
  EXPECT_TRUE(f.isZero());
  EXPECT_TRUE(tau.isApprox(l.m * R_WB.col(0), 1e-12));
  // a torque -|M| x_B turns z_B towards +y_B
  const Eigen::Vector3d dz = tau.cross(R_WB.col(2));
  EXPECT_GT(dz.dot(R_WB.col(1)), 0.0);
  c.mode = BevelLoadMode::kForce;
  CalcBevelTipLoad(c, l, R_WB, f, tau);
  EXPECT_TRUE(f.isApprox(l.q * R_WB.col(1), 1e-12));
  EXPECT_TRUE(tau.isZero());
  c.enabled = false;
  CalcBevelTipLoad(c, l, R_WB, f, tau);
  EXPECT_TRUE(f.isZero() && tau.isZero());
}

TEST(BevelTipTest, BadInputNamesTheKey) {
  BevelConfig c;
  c.bevel_angle = 2.0;
  try {
    c.Validate("coupling.bevel");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("coupling.bevel.bevel_angle"), std::string::npos);
  }
  c = BevelConfig{};
  c.tissue_stiffness = -1;
  EXPECT_THROW(CalcBevelLoads(c), InputError);
  c = BevelConfig{};
  c.diameter = 0;
  EXPECT_THROW(c.Validate(), InputError);
}

}  // namespace
}  // namespace nsim
