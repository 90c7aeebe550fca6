#include "common/needle/beam_needle.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/constraints/constraint_solver.h"
#include "common/core/error.h"

namespace nsim {
namespace {

// Euler-Bernoulli elements are nodally exact for end loads; what remains is the co-rotational
// (geometric) nonlinearity, of order (deflection / L)^2 = 1e-6 here, and the few quasi-static
// steps' residual dynamics
constexpr double kBeamRelTol = 1e-4;
constexpr double kRoundOff = 1e-12;

BeamNeedleConfig MakeConfig() {
  BeamNeedleConfig c;  // 20 cm, r 0.6 mm, E 5 GPa
  c.num_elements = 10;
  c.time_step = 0.02;
  c.rayleigh_mass = 5.0;  // damps the residual dynamics of the quasi-static steps
  return c;
}

// steps until the needle is at rest
void Settle(BeamNeedleBody& body, int steps) {
  for (int k = 0; k < steps; ++k) {
    body.BeginStep();
    body.EndStep();
  }
}

TEST(BeamNeedleTest, CantileverTipForceMatchesBeamTheory) {
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  BeamNeedleBody body(model, state);
  const double L = model.length(), EI = model.bending_stiffness();
  const double delta = 1e-3 * L;  // small deflection
  const double P = 3 * EI * delta / (L * L * L);
  state.external_forces.col(model.num_nodes() - 1) = Eigen::Vector3d(P, 0, 0);
  Settle(body, 200);
  const Eigen::Vector3d tip = state.x.col(model.num_nodes() - 1);
  EXPECT_NEAR(tip.x(), P * L * L * L / (3 * EI), kBeamRelTol * delta);
  EXPECT_NEAR(tip.y(), 0.0, kBeamRelTol * delta);
  // slope at the tip P L^2 / (2 EI): rotation about +y turns z towards +x
  const Eigen::Vector3d z_tip = state.R.back().col(2);
  EXPECT_NEAR(z_tip.x(), P * L * L / (2 * EI), kBeamRelTol * P * L * L / (2 * EI));
  // deflection along the beam: P s^2 (3L - s) / (6 EI)
  for (int k = 0; k < model.num_nodes(); ++k) {
    const double s = k * model.element_length();
    EXPECT_NEAR(state.x(0, k), P * s * s * (3 * L - s) / (6 * EI), kBeamRelTol * delta);
  }
}

TEST(BeamNeedleTest, CantileverTipTorqueMatchesBeamTheory) {
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  BeamNeedleBody body(model, state);
  const double L = model.length(), EI = model.bending_stiffness();
  const double M = 2e-3 * EI / L;  // tip rotation 2e-3 rad
  // a torque about -x turns z towards +y
  state.external_torques.col(model.num_nodes() - 1) = Eigen::Vector3d(-M, 0, 0);
  Settle(body, 200);
  const Eigen::Vector3d tip = state.x.col(model.num_nodes() - 1);
  const double expected = M * L * L / (2 * EI);
  EXPECT_NEAR(tip.y(), expected, kBeamRelTol * expected);
  EXPECT_NEAR(tip.x(), 0.0, kBeamRelTol * expected);
}

TEST(BeamNeedleTest, RotatedFlangeRotatesTheSolution) {
  // the same load in a rotated and translated flange frame gives the rotated deflection
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState a(model), b(model);
  BeamNeedleBody body_a(model, a), body_b(model, b);
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  X_WF.linear() =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  X_WF.translation() = Eigen::Vector3d(0.3, -0.1, 0.2);
  ResetBeamNeedle(model, X_WF, b);
  const int tip = model.num_nodes() - 1;
  const Eigen::Vector3d f(0.01, -0.005, 0.02);
  a.external_forces.col(tip) = f;
  b.external_forces.col(tip) = X_WF.linear() * f;
  Settle(body_a, 100);
  Settle(body_b, 100);
  for (int k = 0; k <= tip; ++k)
    EXPECT_TRUE((X_WF * Eigen::Vector3d(a.x.col(k))).isApprox(b.x.col(k), 1e-9));
}

TEST(BeamNeedleTest, RigidMotionHasNoElasticForce) {
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  X_WF.linear() = Eigen::AngleAxisd(2.5, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  X_WF.translation() = Eigen::Vector3d(1, 2, 3);
  ResetBeamNeedle(model, X_WF, state);
  Eigen::Matrix3Xd f, tau;
  CalcBeamElasticForces(model, state, f, tau);
  EXPECT_LT(f.cwiseAbs().maxCoeff(), kRoundOff * model.axial_stiffness());
  EXPECT_LT(tau.cwiseAbs().maxCoeff(), kRoundOff * model.axial_stiffness());
}

TEST(BeamNeedleTest, ElasticForcesAreInEquilibrium) {
  // internal forces of a deformed needle have zero net force; their net torque about the
  // origin vanishes up to the co-rotational approximation (order of the local strains)
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  const int n = model.num_nodes();
  for (int k = 1; k < n; ++k) {
    state.x.col(k) += 1e-4 * Eigen::Vector3d(std::sin(k), std::cos(2 * k), 0.1 * k);
    state.R[k] = Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d(1, -1, 0.5).normalized()) *
                 state.R[k];
  }
  Eigen::Matrix3Xd f, tau;
  CalcBeamElasticForces(model, state, f, tau);
  const Eigen::Vector3d net_f = f.rowwise().sum();
  Eigen::Vector3d net_tau = tau.rowwise().sum();
  for (int k = 0; k < n; ++k) net_tau += Eigen::Vector3d(state.x.col(k)).cross(f.col(k));
  const double scale = f.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  EXPECT_LT(net_f.norm(), 1e-9 * scale);
  // the co-rotational moments balance up to the largest nodal rotation (0.1 rad) times the
  // force-arm scale
  constexpr double kMaxRotation = 0.1;
  EXPECT_LT(net_tau.norm(), kMaxRotation * scale * model.element_length());
}

TEST(BeamNeedleTest, ComplianceHoldsTheTipAtAPrescribedDeflection) {
  // a bilateral row holds the tip at delta laterally; with a long step (quasi-static) its
  // force is the cantilever stiffness 3 EI / L^3 times delta
  BeamNeedleConfig c = MakeConfig();
  c.time_step = 10.0;  // m / (k h^2) ~ 1e-5: the step is quasi-static
  c.rayleigh_mass = 0.0;
  const BeamNeedleModel model(c);
  BeamNeedleState state(model);
  BeamNeedleBody body(model, state);
  const double L = model.length(), EI = model.bending_stiffness();
  const double delta = 1e-4 * L;
  const int tip = model.num_nodes() - 1;
  body.BeginStep();
  ConstraintSet set;
  const int b = set.AddBody(body);
  const int p = set.AddNodePoint(b, tip);
  const Eigen::Vector3d target = state.x.col(tip) + Eigen::Vector3d(0, delta, 0);
  const int q = set.AddKinematicPoint(target, target);
  set.AddBilateral(p, q, Eigen::Vector3d::UnitY());
  ConstraintSolver solver;
  solver.Solve(set);
  body.EndStep();
  EXPECT_NEAR(state.x(1, tip), delta, kBeamRelTol * delta);
  EXPECT_NEAR(solver.lambda()[0], 3 * EI * delta / (L * L * L),
              kBeamRelTol * 3 * EI * delta / (L * L * L));
}

TEST(BeamNeedleTest, BaseFollowsTheFlangeExactly) {
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  BeamNeedleBody body(model, state);
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  for (int k = 1; k <= 20; ++k) {
    X_WF.translation() = Eigen::Vector3d(0.001 * k, 0, 0.002 * k);
    X_WF.linear() = Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitY()).toRotationMatrix();
    SetBeamNeedleTarget(model, X_WF, state);
    body.BeginStep();
    body.EndStep();
    EXPECT_TRUE(state.x.col(0).isApprox(X_WF.translation(), kRoundOff));
    EXPECT_TRUE(state.R[0].isApprox(X_WF.linear(), kRoundOff));
  }
}

// The free motion's sensitivity to the base target against free motions with a perturbed
// target (a bent, moving needle whose step turns its base): translations exactly (the free
// motion is affine in the target position: round-off), rotations by central differences
// (second order: the remainder O(eps^2) ~ 1e-12 of the O(1) entries).
TEST(BeamNeedleTest, FreeMotionSensitivityMatchesPerturbedFreeMotions) {
  const BeamNeedleModel model(MakeConfig());
  BeamNeedleState state(model);
  const int n = model.num_nodes();
  {
    BeamNeedleBody body(model, state);
    state.external_forces.col(n - 1) = Eigen::Vector3d(0.05, -0.02, 0.0);
    Settle(body, 5);  // bent and still moving
  }
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  X_WF.translation() = Eigen::Vector3d(1e-3, -2e-3, 3e-3);
  X_WF.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  // the free motion (positions and rotation increments, 3 x 2n) for a base target
  auto free_motion = [&](const Eigen::Isometry3d& X_WBase) {
    BeamNeedleState s = state;
    BeamNeedleBody body(model, s);
    s.X_WBase_target = X_WBase;
    body.BeginStep();
    Eigen::Matrix3Xd out = body.free_positions();
    body.EndStep();
    return out;
  };
  BeamNeedleState s = state;
  BeamNeedleBody body(model, s);
  SetBeamNeedleTarget(model, X_WF, s);
  const Eigen::Isometry3d X_WBase = s.X_WBase_target;
  body.BeginStep();
  Eigen::MatrixXd S;
  body.CalcFreeMotionSensitivity(S);
  ASSERT_EQ(S.rows(), 6 * n);
  ASSERT_EQ(S.cols(), 6);
  const Eigen::Matrix3Xd x0 = free_motion(X_WBase);
  constexpr double kStep = 1e-4;  // m, rad
  for (int j = 0; j < 6; ++j) {
    Eigen::MatrixXd column(3, 2 * n);
    if (j < 3) {
      Eigen::Isometry3d X = X_WBase;
      X.translation()[j] += kStep;
      column = (free_motion(X) - x0) / kStep;
    } else {
      Eigen::Isometry3d Xp = X_WBase, Xm = X_WBase;
      Xp.linear() = Eigen::AngleAxisd(kStep, Eigen::Vector3d::Unit(j - 3)) * X_WBase.linear();
      Xm.linear() = Eigen::AngleAxisd(-kStep, Eigen::Vector3d::Unit(j - 3)) * X_WBase.linear();
      column = (free_motion(Xp) - free_motion(Xm)) / (2 * kStep);
    }
    const Eigen::Map<const Eigen::VectorXd> expected(column.data(), 6 * n);
    EXPECT_LT((S.col(j) - expected).cwiseAbs().maxCoeff(), j < 3 ? 1e-9 : 1e-7) << "column " << j;
  }
  // the free tip follows a base translation by less than the base (inertia lag), but mostly
  EXPECT_GT(S(3 * (n - 1), 0), 0.5);
  EXPECT_LT(S(3 * (n - 1), 0), 1.0);
}

TEST(BeamNeedleTest, BadConfigNamesTheKey) {
  BeamNeedleConfig c;
  c.num_elements = 0;
  try {
    c.Validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("needle.num_elements"), std::string::npos);
  }
  c = BeamNeedleConfig{};
  c.time_step = 0;
  EXPECT_THROW(BeamNeedleModel{c}, InputError);
  c = BeamNeedleConfig{};
  c.needle.radius = -1;
  EXPECT_THROW(c.Validate(), InputError);
  const BeamNeedleModel model{BeamNeedleConfig{}};
  BeamNeedleState s(model);
  s.external_forces(0, 3) = std::nan("");
  BeamNeedleBody body(model, s);
  EXPECT_THROW(body.BeginStep(), InputError);
}

}  // namespace
}  // namespace nsim
