#include "common/fem/fem_state.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "common/fem/corotational.h"
#include "common/fem/fem_solver.h"

namespace nsim {
namespace {

constexpr double kRoundOff = 1e-12;  // relative

TEST(FemStateTest, RestStateHasNoEnergyButGravity) {
  FemConfig config;
  const FemModel model(MakeBoxTetMesh({4, 4, 4}, {0.03, 0.03, 0.03}, {0, 0, 0.1}), config);
  const FemState state(model);
  EXPECT_EQ(CalcKineticEnergy(model, state), 0.0);
  EXPECT_LT(CalcElasticEnergy(model, state), 1e-30);
  // potential -M g . centroid: centroid height 0.1 + 0.015 (lumped mass keeps the centroid)
  EXPECT_NEAR(CalcGravitationalEnergy(model, state), model.get_total_mass() * 9.81 * 0.115,
              kRoundOff * model.get_total_mass() * 9.81 * 0.115);
}

TEST(FemStateTest, KineticAndElasticEnergyOfSimpleMotions) {
  const FemModel model(MakeBoxTetMesh({4, 3, 5}, {0.03, 0.02, 0.04}), FemConfig{});
  FemState state(model);
  // uniform velocity: 0.5 M |v|^2
  state.v.colwise() = Eigen::Vector3d(0.1, -0.2, 0.3);
  EXPECT_NEAR(CalcKineticEnergy(model, state), 0.5 * model.get_total_mass() * 0.14,
              kRoundOff * model.get_total_mass());
  // uniform stretch eps along x: energy (lambda/2 + mu) eps^2 V, independent of a rigid rotation
  const double eps = 0.01;
  const LameParameters lame = model.get_lame();
  const double expected = (0.5 * lame.lambda + lame.mu) * eps * eps * 0.03 * 0.02 * 0.04;
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
  G(0, 0) += eps;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  state.x = R * G * model.get_rest_positions();
  // the polar factor is exact to kPolarStepTolerance^2 (corotational.h): an error delta in R
  // changes the strain eps by about delta, the energy by 2 delta / eps relative
  EXPECT_NEAR(CalcElasticEnergy(model, state), expected,
              2.0 * kPolarStepTolerance * kPolarStepTolerance / eps * expected);
}

// copies are independent: stepping a copy leaves the original untouched, and stepping the
// original afterwards gives the same result as the copy did
TEST(FemStateTest, CopyEvaluatesPerturbationWithoutSideEffects) {
  FemConfig config;
  config.linear_solver = FemLinearSolver::kDirect;
  const TetMesh mesh = MakeBoxTetMesh({4, 4, 4}, {0.03, 0.03, 0.03});
  std::vector<int> bottom;
  for (int i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.X(2, i) == 0.0) bottom.push_back(i);
  const FemModel model(mesh, config, {bottom, {}});
  FemSolver solver(model);
  FemState state(model);
  solver.Step(state);
  const FemState saved = state;
  FemState copy = state;
  copy.external_forces.col(50).z() = 0.05;  // a perturbation
  solver.Step(copy);
  EXPECT_EQ(state.x, saved.x);
  EXPECT_EQ(state.v, saved.v);
  EXPECT_EQ(state.time, saved.time);
  EXPECT_GT((copy.x - state.x).norm(), 0.0);
  FemState again = saved;
  again.external_forces.col(50).z() = 0.05;
  solver.Step(again);
  EXPECT_LT((again.x - copy.x).norm(), 1e-13 * copy.x.norm());
}

}  // namespace
}  // namespace nsim
