#include "common/constraints/constraint_solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/constraints/dense_linear_body.h"
#include "common/core/error.h"
#include "tests/constraints/test_helpers.h"

namespace nsim {
namespace {

using testing::MakeChainConfig;
using testing::MakeParticleConfig;

constexpr double kHoldTolerance = 1e-8;  // m: a bilateral row is met to this
constexpr double kPgsTolerance = 1e-12;  // m: PGS stopping residual used in these tests
constexpr double kGapTolerance = 1e-10;  // m: allowed penetration of a contact
constexpr double kConeSlack = 1e-9;      // relative: |lambda_t| <= mu lambda_n (1 + slack)
const Eigen::Vector3d kGravity(0.0, 0.0, -9.81);

ConstraintSolverConfig PgsConfig() {
  ConstraintSolverConfig c;
  c.pgs_tolerance = kPgsTolerance;
  c.pgs_max_iterations = 5000;
  return c;
}

// a free particle held on a moving kinematic target: the point follows it, and a target at rest
// carries exactly the weight
TEST(ConstraintSolverTest, BilateralHoldsPointOnMovingTarget) {
  const double mass = 0.5, h = 0.01, radius = 0.05, omega = 3.0;
  DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d(radius, 0, 0), mass, h, kGravity));
  ConstraintSolver solver;
  ConstraintSet set;
  auto target = [&](double t) {
    return Eigen::Vector3d(radius * std::cos(omega * t), radius * std::sin(omega * t), 0.0);
  };
  double t = 0.0;
  for (int step = 0; step < 200; ++step) {
    // the target moves for 100 steps, then stops
    const double t_end = step < 100 ? t + h : 100 * h;
    const double t_start = step < 100 ? t : 100 * h;
    body.SolveFreeMotion();
    set.Clear();
    const int b = set.AddBody(body);
    const int p = set.AddNodePoint(b, 0);
    const int k = set.AddKinematicPoint(target(t_start), target(t_end));
    set.AddBilateral(p, k, Eigen::Matrix3d::Identity());
    const ConstraintSolveReport report = solver.Solve(set);
    EXPECT_EQ(report.method, ConstraintMethod::kDirect);
    EXPECT_FALSE(report.regularized);
    ASSERT_LE((body.positions().col(0) - target(t_end)).norm(), kHoldTolerance) << step;
    EXPECT_LE(report.max_violation, kHoldTolerance);
    t += h;
  }
  // at rest (velocity zero since step 101) the hold carries the weight: lambda = -m g
  const Eigen::Vector3d force = solver.lambda();
  EXPECT_NEAR(force.z(), mass * 9.81, 1e-9 * mass * 9.81);
  EXPECT_NEAR(force.head<2>().norm(), 0.0, 1e-9 * mass * 9.81);
  // the force on the kinematic point is the reaction
  EXPECT_LE((solver.CalcPointForce(set, 1) + force).norm(), 1e-12);
}

// a soft row (ConstraintRow::softness s) is a spring in series with the body: alone, it removes
// the fraction 1 / (1 + s) of the free violation, with the force of a rigid hold times 1 / (1 + s);
// with s = 0 it is the rigid hold bit for bit; a bad softness is refused
TEST(ConstraintSolverTest, SoftRowRemovesItsFractionOfTheViolation) {
  const double mass = 0.5, h = 0.01;
  const Eigen::Vector3d goal(0.002, -0.001, 0.003);  // the kinematic point, 3.7 mm away
  auto solve = [&](double softness, Eigen::Vector3d* position, Eigen::Vector3d* force) {
    DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), mass, h, Eigen::Vector3d::Zero()));
    body.SolveFreeMotion();
    ConstraintSet set;
    const int b = set.AddBody(body);
    const int p = set.AddNodePoint(b, 0);
    const int k = set.AddKinematicPoint(goal, goal);
    set.AddBilateral(p, k, Eigen::Matrix3d::Identity());
    if (softness > 0) set.SetSoftness(0, 3, softness);
    ConstraintSolver solver;
    EXPECT_TRUE(solver.Solve(set).converged);
    *position = body.positions().col(0);
    *force = solver.lambda();
  };
  Eigen::Vector3d rigid_x, rigid_f, x, f;
  solve(0.0, &rigid_x, &rigid_f);
  EXPECT_LE((rigid_x - goal).norm(), kHoldTolerance);
  for (double s : {0.25, 1.0, 9.0}) {
    solve(s, &x, &f);
    EXPECT_LE((x - goal / (1.0 + s)).norm(), 1e-12) << s;
    EXPECT_LE((f - rigid_f / (1.0 + s)).norm(), 1e-9 * rigid_f.norm()) << s;
  }
  ConstraintSet set;
  DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), mass, h, Eigen::Vector3d::Zero()));
  const int b = set.AddBody(body);
  set.AddBilateral(set.AddNodePoint(b, 0), set.AddKinematicPoint(goal, goal), Eigen::Matrix3d::Identity());
  EXPECT_THROW(set.SetSoftness(0, 3, -1.0), InputError);
  EXPECT_THROW(set.SetSoftness(0, 3, std::numeric_limits<double>::quiet_NaN()), InputError);
  EXPECT_THROW(set.SetSoftness(2, 2, 1.0), InputError);
}

// a row's own compliance c (ConstraintRow::compliance, m/N) is a spring in series with the body
// whatever the body's compliance W: alone, the row removes the fraction W / (W + c) of the free
// violation, with the force of a rigid hold times W / (W + c) (Hooke's law for two springs in
// series); with softness s as well, W (1 + s) + c; a bad compliance is refused
TEST(ConstraintSolverTest, RowComplianceIsASpringInSeries) {
  const double mass = 0.5, h = 0.01;
  const Eigen::Vector3d goal(0.002, -0.001, 0.003);
  auto solve = [&](double softness, double compliance, Eigen::Vector3d* position,
                   Eigen::Vector3d* force, double* body_compliance) {
    DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), mass, h, Eigen::Vector3d::Zero()));
    body.SolveFreeMotion();
    ConstraintSet set;
    const int b = set.AddBody(body);
    set.AddBilateral(set.AddNodePoint(b, 0), set.AddKinematicPoint(goal, goal),
                     Eigen::Matrix3d::Identity());
    if (softness > 0) set.SetSoftness(0, 3, softness);
    if (compliance > 0) set.SetCompliance(0, 3, compliance);
    ConstraintSolver solver;
    EXPECT_TRUE(solver.Solve(set).converged);
    *position = body.positions().col(0);
    *force = solver.lambda();
    *body_compliance = solver.W()(0, 0);
  };
  Eigen::Vector3d rigid_x, rigid_f, x, f;
  double W = 0.0, assembled = 0.0;
  solve(0.0, 0.0, &rigid_x, &rigid_f, &W);
  EXPECT_NEAR(W, h * h / mass, 1e-15);  // a free particle: h^2 / m
  for (double c : {0.1 * W, W, 20.0 * W}) {
    solve(0.0, c, &x, &f, &assembled);
    EXPECT_NEAR(assembled, W + c, 1e-15 * (W + c)) << c;
    const double fraction = W / (W + c);
    EXPECT_LE((x - fraction * goal).norm(), 1e-12) << c;
    EXPECT_LE((f - fraction * rigid_f).norm(), 1e-9 * rigid_f.norm()) << c;
    // with a softness too: W (1 + s) + c
    solve(1.5, c, &x, &f, &assembled);
    EXPECT_LE((x - W / (2.5 * W + c) * goal).norm(), 1e-12) << c;
  }
  ConstraintSet set;
  DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), mass, h, Eigen::Vector3d::Zero()));
  const int b = set.AddBody(body);
  set.AddBilateral(set.AddNodePoint(b, 0), set.AddKinematicPoint(goal, goal), Eigen::Matrix3d::Identity());
  EXPECT_THROW(set.SetCompliance(0, 3, -1e-3), InputError);
  EXPECT_THROW(set.SetCompliance(0, 3, std::numeric_limits<double>::infinity()), InputError);
  EXPECT_THROW(set.SetCompliance(1, 3, 1e-3), InputError);
}

// two spring chains coupled by a bilateral joint: the joint impulses cancel, so the total
// momentum changes only by the external impulse, and the joint holds
TEST(ConstraintSolverTest, TwoCoupledBodiesConserveMomentum) {
  const double h = 0.01;
  DenseLinearBody a(
      MakeChainConfig(3, 0.2, 0.02, 40.0, h, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d::Zero()));
  DenseLinearBody b(MakeChainConfig(4, 0.1, 0.02, 25.0, h, Eigen::Vector3d(0.05, 0.01, 0),
                                    Eigen::Vector3d::Zero()));
  const Eigen::Vector3d push(0.3, -0.2, 0.5);
  a.external_forces().col(0) = push;
  ConstraintSolver solver;
  ConstraintSet set;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  for (int step = 0; step < 60; ++step) {
    a.SolveFreeMotion();
    b.SolveFreeMotion();
    set.Clear();
    const int ia = set.AddBody(a), ib = set.AddBody(b);
    const int pa = set.AddNodePoint(ia, 2);
    const int pb = set.AddBodyPoint(ib, std::vector<int>{0, 1}, std::vector<double>{0.7, 0.3});
    if (step == 0) offset = set.CalcStartPosition(pa) - set.CalcStartPosition(pb);
    set.AddBilateral(pa, pb, Eigen::Matrix3d::Identity(), offset);
    solver.Solve(set);
    // the impulses on the two bodies cancel
    const Eigen::Vector3d fa = solver.CalcPointForce(set, pa), fb = solver.CalcPointForce(set, pb);
    ASSERT_LE((fa + fb).norm(), 1e-12 * (fa.norm() + 1e-30)) << step;
    const std::vector<const Eigen::Matrix3Xd*> x{&a.positions(), &b.positions()};
    ASSERT_LE((set.CalcPointPosition(pa, x) - set.CalcPointPosition(pb, x) - offset).norm(),
              kHoldTolerance);
  }
  // both bodies started at rest
  const Eigen::Vector3d momentum = a.CalcMomentum() + b.CalcMomentum();
  const Eigen::Vector3d expected = 60 * h * push;
  EXPECT_LE((momentum - expected).norm(), 1e-10 * expected.norm());
  // the joint was loaded (the test is not trivially satisfied)
  EXPECT_GT(solver.lambda().norm(), 1e-3);
}

// one particle on the floor z = 0 (kinematic point at the origin, normal +z)
struct FloorScene {
  DenseLinearBody body;
  ConstraintSolver solver;
  ConstraintSet set;
  double mu = -1.0;  // < 0: frictionless contact

  FloorScene(double mass, double h, double z0)
      : body(MakeParticleConfig(Eigen::Vector3d(0, 0, z0), mass, h, kGravity)),
        solver(PgsConfig()) {}

  ConstraintSolveReport Step() {
    body.SolveFreeMotion();
    set.Clear();
    const int b = set.AddBody(body);
    const int p = set.AddNodePoint(b, 0);
    const int floor = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    if (mu < 0)
      set.AddContact(p, floor, Eigen::Vector3d::UnitZ());
    else
      set.AddFrictionContact(p, floor, Eigen::Vector3d::UnitZ(), mu);
    return solver.Solve(set);
  }
};

TEST(ConstraintSolverTest, ContactNeverPenetratesAndReleasesWhenPulled) {
  const double mass = 0.3, h = 0.01, push = 5.0;
  FloorScene s(mass, h, 0.01);
  s.body.external_forces().col(0) = Eigen::Vector3d(0, 0, -push);
  bool touched = false;
  for (int step = 0; step < 100; ++step) {
    const ConstraintSolveReport r = s.Step();
    ASSERT_TRUE(r.converged) << step;
    EXPECT_EQ(r.method, ConstraintMethod::kPgs);
    ASSERT_GE(s.body.positions()(2, 0), -kGapTolerance) << step;
    ASSERT_GE(s.solver.lambda()[0], 0.0);
    touched = touched || s.solver.lambda()[0] > 0.0;
  }
  ASSERT_TRUE(touched);
  // resting: the floor carries weight + push
  EXPECT_NEAR(s.solver.lambda()[0], mass * 9.81 + push, 1e-9 * (mass * 9.81 + push));
  EXPECT_NEAR(s.body.positions()(2, 0), 0.0, kGapTolerance);
  // pulled up harder than gravity: the contact releases at once and the particle accelerates
  const double pull = 10.0;
  s.body.external_forces().col(0) = Eigen::Vector3d(0, 0, pull);
  for (int step = 1; step <= 10; ++step) {
    const ConstraintSolveReport r = s.Step();
    ASSERT_TRUE(r.converged);
    ASSERT_EQ(s.solver.lambda()[0], 0.0) << step;
    EXPECT_NEAR(s.body.velocities()(2, 0), step * h * (pull / mass - 9.81), 1e-12);
  }
  EXPECT_GT(s.body.positions()(2, 0), 0.0);
}

TEST(ConstraintSolverTest, FrictionSticksInsideConeAndSlipsOutside) {
  const double mass = 0.4, h = 0.01, mu = 0.5;
  const double normal = mass * 9.81;
  const Eigen::Vector3d dir = Eigen::Vector3d(1.0, 2.0, 0.0).normalized();
  for (const double ratio : {0.4, 0.95, 1.5, 3.0}) {
    SCOPED_TRACE(ratio);
    FloorScene s(mass, h, 0.0);
    s.mu = mu;
    const double tangential = ratio * mu * normal;
    s.body.external_forces().col(0) = tangential * dir;
    const int steps = 50;
    for (int step = 0; step < steps; ++step) {
      const ConstraintSolveReport r = s.Step();
      ASSERT_TRUE(r.converged) << step << " residual " << r.residual;
      const Eigen::Vector3d l = s.solver.lambda();
      ASSERT_LE(l.tail<2>().norm(), mu * l[0] * (1.0 + kConeSlack));
      ASSERT_GE(s.body.positions()(2, 0), -kGapTolerance);
      EXPECT_NEAR(l[0], normal, 1e-9 * normal);
    }
    const Eigen::Vector3d force = s.solver.CalcPointForce(s.set, 0);
    const Eigen::Vector3d slide = s.body.positions().col(0) - Eigen::Vector3d::Zero();
    if (ratio < 1.0) {
      // sticks: no motion, friction balances the load
      EXPECT_LE(slide.norm(), kHoldTolerance);
      EXPECT_LE((force.head<2>() + tangential * dir.head<2>()).norm(), 1e-9 * normal);
    } else {
      // slips: friction mu N against the motion, v = t (F - mu N) / m exactly (implicit Euler
      // with constant forces)
      const double accel = (tangential - mu * normal) / mass;
      EXPECT_NEAR(s.body.velocities().col(0).dot(dir), steps * h * accel, 1e-9 * steps * h * accel);
      EXPECT_LE((s.body.velocities().col(0).head<2>().normalized() - dir.head<2>()).norm(), 1e-9);
      EXPECT_NEAR(force.head<2>().norm(), mu * normal, 1e-9 * normal);
      EXPECT_LE((force.head<2>().normalized() + dir.head<2>()).norm(), 1e-9);
    }
  }
}

// a spring chain on a tilted floor with friction: the block solve keeps every contact inside
// the cone, the converged residual is met and nothing penetrates
TEST(ConstraintSolverTest, FrictionOnCoupledBodyStaysInConeAndConverges) {
  const double h = 0.01, mu = 0.3;
  DenseLinearBodyConfig c =
      MakeChainConfig(5, 0.05, 0.01, 200.0, h, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  // gravity tilted 25 degrees off the floor normal: above mu = 0.3 (tan 25 deg = 0.47)
  const double tilt = 25.0 * M_PI / 180.0;
  c.gravity = 9.81 * Eigen::Vector3d(std::sin(tilt), 0.2 * std::sin(tilt), -std::cos(tilt));
  DenseLinearBody body(c);
  ConstraintSolver solver(PgsConfig());
  ConstraintSet set;
  int slip_steps = 0;
  for (int step = 0; step < 40; ++step) {
    body.SolveFreeMotion();
    set.Clear();
    const int b = set.AddBody(body);
    const int floor = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    for (int i = 0; i < body.num_nodes(); ++i)
      set.AddFrictionContact(set.AddNodePoint(b, i), floor, Eigen::Vector3d::UnitZ(), mu);
    const ConstraintSolveReport r = solver.Solve(set);
    ASSERT_TRUE(r.converged) << step << " residual " << r.residual;
    for (int g = 0; g < set.num_groups(); ++g) {
      const Eigen::Vector3d l = solver.lambda().segment<3>(3 * g);
      ASSERT_GE(l[0], 0.0);
      ASSERT_LE(l.tail<2>().norm(), mu * l[0] * (1.0 + kConeSlack));
      if (l[0] > 0 && l.tail<2>().norm() >= mu * l[0] * (1.0 - kConeSlack)) ++slip_steps;
    }
    ASSERT_LE(r.max_violation, kGapTolerance);
  }
  // the block slides (tilt above the friction angle): total normal = weight normal component
  EXPECT_GT(slip_steps, 0);
  const double total_normal = solver.lambda()(Eigen::seq(0, Eigen::last, 3)).sum();
  EXPECT_NEAR(total_normal, 5 * 0.05 * 9.81 * std::cos(tilt), 1e-6);
}

// all contacts in compression and frictionless: no inequality is active, so PGS must give the
// solution of W lambda = -delta, i.e. the direct solve of the same rows made bilateral
TEST(ConstraintSolverTest, PgsEqualsDirectWhenNoInequalityActive) {
  const double h = 0.02;
  DenseLinearBodyConfig c =
      MakeChainConfig(4, 0.1, 0.03, 80.0, h, Eigen::Vector3d::Zero(), kGravity);
  DenseLinearBody body(c);
  // uneven loads so the contacts interact through the springs
  body.external_forces().row(2) << -0.5, -1.0, -0.3, -0.8;
  body.SolveFreeMotion();
  const int n = body.num_nodes();

  auto build = [&](ConstraintSet& set, bool bilateral) {
    set.Clear();
    const int b = set.AddBody(body);
    const int floor = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    const Eigen::Vector3d normal = Eigen::Vector3d(0.0, 0.1, 1.0).normalized();
    for (int i = 0; i < n; ++i) {
      const int p = set.AddNodePoint(b, i);
      if (bilateral)
        set.AddBilateral(p, floor, normal);
      else
        set.AddContact(p, floor, normal);
    }
  };
  ConstraintSet contact_set, bilateral_set;
  build(contact_set, false);
  build(bilateral_set, true);
  ConstraintSolver pgs(PgsConfig()), direct;
  pgs.Assemble(contact_set);
  const ConstraintSolveReport rp = pgs.SolveMultipliers(contact_set);
  direct.Assemble(bilateral_set);
  const ConstraintSolveReport rd = direct.SolveMultipliers(bilateral_set);
  ASSERT_EQ(rp.method, ConstraintMethod::kPgs);
  ASSERT_EQ(rd.method, ConstraintMethod::kDirect);
  ASSERT_TRUE(rp.converged);
  EXPECT_GT(rp.iterations, 1);              // the rows are coupled
  ASSERT_GT(pgs.lambda().minCoeff(), 0.0);  // every contact pushes: no inequality at its bound
  const double scale = direct.lambda().cwiseAbs().maxCoeff();
  EXPECT_LE((pgs.lambda() - direct.lambda()).cwiseAbs().maxCoeff(), 1e-8 * scale);

  // the bilateral set itself by PGS and by LDLT agree too
  ConstraintSolverConfig forced = PgsConfig();
  forced.method = ConstraintMethod::kPgs;
  ConstraintSolver pgs_bilateral(forced);
  pgs_bilateral.Assemble(bilateral_set);
  const ConstraintSolveReport rb = pgs_bilateral.SolveMultipliers(bilateral_set);
  ASSERT_TRUE(rb.converged);
  EXPECT_LE((pgs_bilateral.lambda() - direct.lambda()).cwiseAbs().maxCoeff(), 1e-8 * scale);
}

// a point held twice by identical rows: W is singular, the solve is regularized, the point is
// still held and the total force equals that of a single hold
TEST(ConstraintSolverTest, RedundantBilateralRowsAreRegularized) {
  const double mass = 0.2, h = 0.01;
  auto run = [&](int copies, Eigen::Vector3d& total, ConstraintSolveReport& report) {
    DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), mass, h, kGravity));
    body.SolveFreeMotion();
    ConstraintSet set;
    const int b = set.AddBody(body);
    const int p = set.AddNodePoint(b, 0);
    const Eigen::Vector3d goal(0.001, 0.0, 0.002);
    const int k = set.AddKinematicPoint(goal, goal);
    for (int i = 0; i < copies; ++i) set.AddBilateral(p, k, Eigen::Matrix3d::Identity());
    ConstraintSolver solver;
    report = solver.Solve(set);
    total = solver.CalcPointForce(set, p);
    EXPECT_LE((body.positions().col(0) - goal).norm(), kHoldTolerance);
  };
  Eigen::Vector3d single, doubled;
  ConstraintSolveReport r1, r2;
  run(1, single, r1);
  run(2, doubled, r2);
  EXPECT_FALSE(r1.regularized);
  EXPECT_TRUE(r2.regularized);
  EXPECT_LE((single - doubled).norm(), 1e-6 * single.norm());
}

TEST(ConstraintSolverTest, RowsWithoutCompliantPointAreDegenerate) {
  DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), 1.0, 0.01, kGravity));
  body.SolveFreeMotion();
  ConstraintSet set;
  set.AddBody(body);
  const int k1 = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const int k2 = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  set.AddBilateral(k1, k2, Eigen::Vector3d::UnitX());
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(set);
  EXPECT_EQ(r.num_degenerate_rows, 1);
  EXPECT_EQ(solver.lambda()[0], 0.0);
  EXPECT_NEAR(r.max_violation, 1.0, 1e-15);  // reported, not hidden
}

TEST(ConstraintSolverTest, RejectsDirectMethodWithContactsAndUngroupedRows) {
  DenseLinearBody body(MakeParticleConfig(Eigen::Vector3d::Zero(), 1.0, 0.01, kGravity));
  body.SolveFreeMotion();
  ConstraintSet set;
  const int b = set.AddBody(body);
  const int p = set.AddNodePoint(b, 0);
  const int k = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  set.AddContact(p, k, Eigen::Vector3d::UnitZ());
  ConstraintSolverConfig c;
  c.method = ConstraintMethod::kDirect;
  ConstraintSolver direct(c);
  try {
    direct.Solve(set);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bilateral rows only"), std::string::npos) << e.what();
  }
  set.AddRow({{p, Eigen::Vector3d::UnitX()}}, 0.0);
  ConstraintSolver solver;
  try {
    solver.Solve(set);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1 rows are ungrouped"), std::string::npos) << e.what();
  }
}

// a solve stopped by its cap, or with a non-finite lambda, says so (converged = false) with the
// residual and violation of where it stopped
TEST(ConstraintSolverTest, CapsAndNonFiniteResultsAreReportedAsNotConverged) {
  // PGS: coupled contacts need more than one sweep
  DenseLinearBodyConfig c =
      MakeChainConfig(4, 0.1, 0.03, 80.0, 0.02, Eigen::Vector3d::Zero(), kGravity);
  DenseLinearBody chain(c);
  chain.SolveFreeMotion();
  ConstraintSet contacts;
  const int b = contacts.AddBody(chain);
  const int floor = contacts.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (int i = 0; i < chain.num_nodes(); ++i)
    contacts.AddContact(contacts.AddNodePoint(b, i), floor, Eigen::Vector3d::UnitZ());
  ConstraintSolverConfig one_sweep;
  one_sweep.pgs_max_iterations = 1;
  ConstraintSolver pgs(one_sweep);
  pgs.Assemble(contacts);
  const ConstraintSolveReport rp = pgs.SolveMultipliers(contacts);
  EXPECT_EQ(rp.method, ConstraintMethod::kPgs);
  EXPECT_FALSE(rp.converged);
  EXPECT_EQ(rp.iterations, 1);
  EXPECT_GT(rp.residual, one_sweep.pgs_tolerance);

  // active set: axial friction that slips needs a second solve (stick, then at the bound)
  DenseLinearBody particle(MakeParticleConfig(Eigen::Vector3d::Zero(), 0.01, 0.02, kGravity));
  particle.SolveFreeMotion();
  ConstraintSet needle;
  const int pb = needle.AddBody(particle);
  const int p = needle.AddNodePoint(pb, 0);
  const int q =
      needle.AddKinematicPoint(Eigen::Vector3d(0, 0.001, 0), Eigen::Vector3d(0.01, 0.001, 0));
  Eigen::Matrix<double, 3, 2> lateral;
  lateral << Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ();
  const int lateral_group = needle.AddBilateral(p, q, lateral);
  needle.AddAxialFriction(p, q, Eigen::Vector3d::UnitX(), lateral_group, 0.2, 0.0);
  ConstraintSolverConfig one_solve;
  one_solve.active_set_max_iterations = 1;
  ConstraintSolver capped(one_solve), full;
  capped.Assemble(needle);
  full.Assemble(needle);
  const ConstraintSolveReport rc = capped.SolveMultipliers(needle);
  const ConstraintSolveReport rf = full.SolveMultipliers(needle);
  EXPECT_EQ(rc.method, ConstraintMethod::kActiveSet);
  EXPECT_FALSE(rc.converged);
  EXPECT_EQ(rc.iterations, 1);
  EXPECT_GT(rc.residual, one_solve.position_tolerance);  // the stick force exceeds the bound
  EXPECT_TRUE(rf.converged);
  EXPECT_EQ(rf.iterations, 2);
  EXPECT_EQ(rf.num_slipping, 1);

  // a non-finite problem
  ConstraintGroup bilateral;
  bilateral.num_rows = 1;
  ConstraintWorkspace ws;
  Eigen::VectorXd lambda;
  const ConstraintSolveReport rn =
      SolveConstraintLaws(Eigen::MatrixXd::Identity(1, 1),
                          Eigen::VectorXd::Constant(1, std::numeric_limits<double>::quiet_NaN()),
                          {bilateral}, ConstraintSolverConfig(), ws, lambda);
  EXPECT_FALSE(rn.converged);
}

// perturbation re-solves (inverse simulation): moving a kinematic point and recomputing delta
// with W unchanged gives the same lambda as a full re-assembly
TEST(ConstraintSolverTest, RecomputeDeltaMatchesFullAssembly) {
  DenseLinearBody body(
      MakeChainConfig(3, 0.1, 0.02, 50.0, 0.01, Eigen::Vector3d::Zero(), kGravity));
  body.SolveFreeMotion();
  auto build = [&](ConstraintSet& set, const Eigen::Vector3d& needle) {
    set.Clear();
    const int b = set.AddBody(body);
    const int p =
        set.AddBodyPoint(b, std::vector<int>{0, 1, 2}, std::vector<double>{0.2, 0.5, 0.3}, 7);
    const int k = set.AddKinematicPoint(needle, needle);
    Eigen::Matrix3Xd dirs(3, 2);
    dirs << 0, 0, 1, 0, 0, 1;
    set.AddBilateral(p, k, dirs);
  };
  ConstraintSet set;
  build(set, Eigen::Vector3d(0.02, 0.0, 0.0));
  ConstraintSolver fast;
  fast.Assemble(set);
  build(set, Eigen::Vector3d(0.02, 0.001, -0.002));
  fast.RecomputeDelta(set);
  fast.SolveMultipliers(set);
  ConstraintSolver full;
  full.Assemble(set);
  full.SolveMultipliers(set);
  EXPECT_LE((fast.lambda() - full.lambda()).norm(), 1e-12 * full.lambda().norm());
  EXPECT_GT(full.lambda().norm(), 0.0);
}

}  // namespace
}  // namespace nsim
