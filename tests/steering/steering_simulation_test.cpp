// The inverse model and its frozen-step perturbation solves: the solve at the unperturbed pose
// reproduces the committed step, and a perturbed solve equals a full re-simulation of the same
// step with the perturbed needle (the two paths DESIGN.md "Speed" says must agree).

#include "common/steering/steering_simulation.h"

#include <gtest/gtest.h>

#include "common/core/error.h"
#include "common/robot/pose_math.h"
#include "tests/steering/steering_test_scene.h"

namespace nsim {
namespace {

using steering_test::LoadLiver;
using steering_test::MakeModelConfig;
using steering_test::MakePathConfig;

constexpr double kAdvancePerStep = 0.002;  // needle advance per step (m)

// flange pose after `step` steps of a straight insertion along the path
Eigen::Isometry3d InsertionPose(const Eigen::Isometry3d& X_WF0, const Eigen::Vector3d& dir,
                                int step) {
  Eigen::Isometry3d X = X_WF0;
  X.translation() += kAdvancePerStep * step * dir;
  return X;
}

std::vector<Eigen::Vector3d> RestMarkers(const InverseModelConfig& c) { return c.markers_W; }

class SteeringSimulationTest : public ::testing::Test {
 protected:
  SteeringSimulationTest()
      : mesh_(LoadLiver("liver_700")),
        model_(MakeModelConfig()),
        path_(MakePathConfig()),
        X_WF0_(SteeringSimulation::CalcStartFlangePose(model_.needle, path_)),
        dir_((path_.target_W - path_.entry_W).normalized()) {}

  // a model advanced by `steps` insertion steps
  std::unique_ptr<SteeringSimulation> Advance(int steps) const {
    auto sim = std::make_unique<SteeringSimulation>(model_, path_, mesh_, X_WF0_);
    for (int i = 1; i <= steps; ++i) sim->Step(RestMarkers(model_), InsertionPose(X_WF0_, dir_, i));
    return sim;
  }

  TetMesh mesh_;
  InverseModelConfig model_;
  SteeringPathConfig path_;
  Eigen::Isometry3d X_WF0_;
  Eigen::Vector3d dir_;
};

// steps that put the tip ~3 cm into the liver (10 mm approach + puncture + 30 mm)
constexpr int kInsideSteps = 25;

TEST_F(SteeringSimulationTest, PuncturesTheLiverAndSeedsPoints) {
  auto sim = Advance(kInsideSteps);
  EXPECT_TRUE(sim->liver_punctured());
  EXPECT_GE(sim->liver_coupling().points.size(), 2u);
  Eigen::Vector3d entry;
  ASSERT_TRUE(sim->CalcLiverEntryPoint(&entry));
  EXPECT_LT((entry - path_.entry_W).norm(), 0.01);
}

TEST_F(SteeringSimulationTest, UnperturbedSolveReproducesTheCommittedStep) {
  auto sim = Advance(kInsideSteps);
  SnapshotWorkspace ws;
  const SteeringEvaluation eval = sim->EvaluateAt(InsertionPose(X_WF0_, dir_, kInsideSteps), ws);
  const std::vector<Eigen::Vector3d> committed = sim->CalcPathPositions();
  ASSERT_EQ(eval.p_WPath.size(), committed.size());
  // positions are O(0.1 m); the correction goes through the same columns: round-off level
  constexpr double kTolerance = 1e-10;  // m
  for (size_t i = 0; i < committed.size(); ++i) {
    EXPECT_LT((eval.p_WPath[i] - committed[i]).norm(), kTolerance) << "path point " << i;
  }
  EXPECT_LT(eval.solve.max_violation, 1e-9);
  // the target moved with the tissue (the needle pushes it): the check is not trivial
  EXPECT_GT((committed.back() - path_.target_W).norm(), 1e-5);
}

TEST_F(SteeringSimulationTest, PerturbedSolveEqualsFullResimulation) {
  auto sim = Advance(kInsideSteps);
  const Eigen::Isometry3d X_nominal = InsertionPose(X_WF0_, dir_, kInsideSteps);
  const SteeringEvaluation nominal = [&] {
    SnapshotWorkspace ws;
    return sim->EvaluateAt(X_nominal, ws);
  }();
  // a lateral translation and a rotation, as large as the Jacobian's perturbations (x 2)
  Vector6d translate = Vector6d::Zero();
  translate[0] = 2e-3;
  Vector6d rotate = Vector6d::Zero();
  rotate[5] = 1e-2;
  for (const Vector6d& delta : {translate, rotate}) {
    const Eigen::Isometry3d X = ApplyPoseIncrement(X_nominal, delta, PoseIncrementFrame::kWorldAligned);
    SnapshotWorkspace ws;
    const SteeringEvaluation fast = sim->EvaluateAt(X, ws);
    // full path: the same history, the last step with the perturbed flange
    auto full = Advance(kInsideSteps - 1);
    full->Step(RestMarkers(model_), X);
    const std::vector<Eigen::Vector3d> reference = full->CalcPathPositions();
    double moved = 0.0;
    for (size_t i = 0; i < reference.size(); ++i) {
      moved = std::max(moved, (reference[i] - nominal.p_WPath[i]).norm());
      // rows turn identically in both paths, so they agree to round-off (m)
      EXPECT_LT((fast.p_WPath[i] - reference[i]).norm(), 1e-9)
          << "path point " << i << ", perturbation " << delta.transpose();
    }
    // the perturbation did move the tissue
    EXPECT_GT(moved, 1e-6) << delta.transpose();
  }
}

TEST_F(SteeringSimulationTest, EvaluationHasNoSideEffects) {
  auto sim = Advance(kInsideSteps);
  const Eigen::Isometry3d X = InsertionPose(X_WF0_, dir_, kInsideSteps);
  SnapshotWorkspace ws;
  const SteeringEvaluation before = sim->EvaluateAt(X, ws);
  Vector6d delta;
  delta << 3e-3, -2e-3, 1e-3, 0.02, -0.01, 0.03;
  sim->EvaluateAt(ApplyPoseIncrement(X, delta, PoseIncrementFrame::kWorldAligned), ws);
  const SteeringEvaluation after = sim->EvaluateAt(X, ws);
  for (size_t i = 0; i < before.p_WPath.size(); ++i) {
    EXPECT_EQ(before.p_WPath[i], after.p_WPath[i]);
  }
}

TEST_F(SteeringSimulationTest, BadInputNamesTheProblem) {
  SteeringSimulation sim(model_, path_, mesh_, X_WF0_);
  try {
    sim.Step({Eigen::Vector3d::Zero()}, X_WF0_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 5 markers, got 1"), std::string::npos);
  }
  InverseModelConfig bad = model_;
  bad.young_modulus_factor = -1.0;
  try {
    SteeringSimulation s(bad, path_, mesh_, X_WF0_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("inverse.young_modulus_factor must be > 0"),
              std::string::npos)
        << e.what();
  }
  InverseModelConfig outside = model_;
  outside.markers_W[2] = Eigen::Vector3d(1.0, 1.0, 1.0);
  EXPECT_THROW(SteeringSimulation(outside, path_, mesh_, X_WF0_), InputError);
}

}  // namespace
}  // namespace nsim
