// The needle's axial friction law (ConstraintLaw::kAxialFriction) in the constraint solver.

#include <gtest/gtest.h>

#include <memory>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/dense_linear_body.h"

namespace nsim {
namespace {

// one particle (mass m) on a spring k to its rest position, held on a "needle" line through a
// kinematic point: lateral rows y, z and an axial friction row x. From rest the free motion
// stays at rest, and the compliance per axis is c = h^2 / (m + h^2 k), so every multiplier is
// known in closed form: lateral lambda = offset / c, stick lambda_x = s / c.
constexpr double kMass = 0.01, kStiffness = 100.0, kH = 0.02;
constexpr double kForceTol = 1e-9;  // N, relative to forces of O(1 N)

struct Problem {
  std::unique_ptr<DenseLinearBody> body;
  ConstraintSet set;
  double c = 0.0;

  // the needle point moves by s along x over the step; the line is offset by b along y; the
  // axial row has the friction law (rows 0, 1 its normal force), or without `friction` is a
  // plain bilateral row
  Problem(double s, double b, double mu, double stiction, bool friction = true) {
    DenseLinearBodyConfig config;
    config.masses = Eigen::VectorXd::Constant(1, kMass);
    config.rest_positions = Eigen::Matrix3Xd::Zero(3, 1);
    config.stiffness = kStiffness * Eigen::MatrixXd::Identity(3, 3);
    config.time_step = kH;
    body = std::make_unique<DenseLinearBody>(config);
    body->SolveFreeMotion();
    c = kH * kH / (kMass + kH * kH * kStiffness);
    const int bi = set.AddBody(*body);
    const int p = set.AddNodePoint(bi, 0);
    const int q = set.AddKinematicPoint(Eigen::Vector3d(0, b, 0), Eigen::Vector3d(s, b, 0));
    Eigen::Matrix<double, 3, 2> lateral;
    lateral << Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ();
    const int lateral_group = set.AddBilateral(p, q, lateral);
    // slip over the step, target 0
    if (friction)
      set.AddAxialFriction(p, q, Eigen::Vector3d::UnitX(), lateral_group, mu, stiction);
    else
      set.AddBilateral(p, q, Eigen::Vector3d::UnitX());
  }
};

TEST(ConstraintAxialFrictionTest, SticksInsideTheCone) {
  const double s = 1e-4, b = 1e-3, mu = 0.5;  // s < mu b: stick
  Problem pb(s, b, mu, 0.0);
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(pb.set);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.num_slipping, 0);
  EXPECT_NEAR(solver.lambda()[0], b / pb.c, kForceTol);
  EXPECT_NEAR(solver.lambda()[2], s / pb.c, kForceTol);
  EXPECT_LT((pb.body->positions().col(0) - Eigen::Vector3d(s, b, 0)).norm(), 1e-12);
}

TEST(ConstraintAxialFrictionTest, SlipsAtMuTimesTheLateralForce) {
  const double s = 1e-3, b = 1e-3, mu = 0.5;  // s > mu b: slip
  Problem pb(s, b, mu, 0.0);
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(pb.set);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.num_slipping, 1);
  const double normal = b / pb.c;
  EXPECT_NEAR(solver.lambda()[0], normal, kForceTol);
  EXPECT_NEAR(solver.lambda()[2], mu * normal, kForceTol);  // drags the particle along +x
  // the particle moved by the friction force only: x = c mu N < s (it slipped)
  EXPECT_NEAR(pb.body->positions()(0, 0), pb.c * mu * normal, 1e-12);
  EXPECT_LT(pb.body->positions()(0, 0), s);
  // backwards motion: the force flips
  Problem back(-s, b, mu, 0.0);
  ConstraintSolver solver2;
  solver2.Solve(back.set);
  EXPECT_NEAR(solver2.lambda()[2], -mu * normal, kForceTol);
}

TEST(ConstraintAxialFrictionTest, StictionAddsToTheBound) {
  // stick would need s / c = 1.25 N > mu N + f0 = 0.525 N: slips at the bound
  const double s = 1e-2, b = 1e-3, mu = 0.2, f0 = 0.5;
  Problem pb(s, b, mu, f0);
  ConstraintSolver solver;
  solver.Solve(pb.set);
  EXPECT_NEAR(solver.lambda()[2], mu * b / pb.c + f0, kForceTol);
  // no lateral offset and no stiction: no friction at all
  Problem free(s, 0.0, mu, 0.0);
  ConstraintSolver solver2;
  solver2.Solve(free.set);
  EXPECT_NEAR(solver2.lambda()[2], 0.0, kForceTol);
  EXPECT_NEAR(free.body->positions()(0, 0), 0.0, 1e-12);
}

TEST(ConstraintAxialFrictionTest, WithoutFrictionRowsUsesTheGenericSolver) {
  Problem pb(1e-4, 1e-3, 0.5, 0.0, /*friction=*/false);
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(pb.set);
  // bilateral rows only: the direct solve
  EXPECT_EQ(r.method, ConstraintMethod::kDirect);
  EXPECT_NEAR(solver.lambda()[2], 1e-4 / pb.c, kForceTol);  // plain bilateral: sticks
}

}  // namespace
}  // namespace nsim
