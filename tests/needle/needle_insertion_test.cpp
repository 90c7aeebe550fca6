#include "common/needle/needle_insertion.h"

#include <gtest/gtest.h>

#include "tests/needle/test_scene.h"

namespace nsim {
namespace {

using testing::DownwardFlange;
using testing::FemBlock;

constexpr double kSide = 0.04;
constexpr double kStepAdvance = 0.5e-3;  // m per 20 ms step
constexpr double kLineTol = 1e-9;        // m, bilateral rows to round-off

TissueCouplingConfig MakeTissue(const char* name) {
  TissueCouplingConfig t;
  t.name = name;
  t.puncture_force = 0.05;
  t.point_spacing = 5e-3;
  t.friction_coefficient = 0.1;
  return t;
}

TEST(NeedleInsertionTest, NeedleLeavesTheSkinAndEntersTheNextTissue) {
  // a 1 cm "skin" slab (bottom fixed at z = 5 cm, the needle pushes it down) 1 cm above a block
  FemBlock skin(Eigen::Vector3i(6, 6, 3), Eigen::Vector3d(kSide, kSide, 0.01),
                Eigen::Vector3d(0, 0, 0.05), 20000.0);
  FemBlock liver(Eigen::Vector3i(6, 6, 6), Eigen::Vector3d(kSide, kSide, kSide),
                 Eigen::Vector3d::Zero());
  // the skin's bottom face is fixed (its support); the needle exits through it
  NeedleCouplingConfig config;
  config.tissues = {MakeTissue("skin"), MakeTissue("liver")};
  const NeedleTissueCoupling coupling(config, {&skin.mesh, &liver.mesh});
  NeedleCouplingState state = coupling.MakeState();
  NeedleInsertionStepper stepper(coupling);
  const RigidNeedleModel needle_model{[] {
    NeedleConfig c;
    c.length = 0.12;
    return c;
  }()};
  RigidNeedleState needle;
  Eigen::Vector3d base(kSide / 2 + 1e-4, kSide / 2 + 2e-4, 0.06 + 1e-3 + 0.12);
  ResetRigidNeedle(needle_model, DownwardFlange(base), needle);
  std::vector<FemConstraintBody*> bodies{skin.body.get(), liver.body.get()};
  double skin_exit_time = -1, liver_puncture_time = -1;
  for (int k = 0; k < 120; ++k) {
    base.z() -= kStepAdvance;
    const size_t held_skin = state.tissues[0].points.size();
    const bool skin_in = state.tissues[0].report.punctured;
    stepper.StepRigid(needle_model, needle, DownwardFlange(base), bodies, state);
    if (state.tissues[0].phase == TissuePhase::kExited && skin_exit_time < 0)
      skin_exit_time = skin.state->time;
    if (state.tissues[1].report.punctured && liver_puncture_time < 0)
      liver_puncture_time = liver.state->time;
    // skin points stay on the needle line while the needle goes on into the liver
    if (!skin_in) continue;
    for (size_t i = 0; i < held_skin && i < state.tissues[0].points.size(); ++i) {
      const Eigen::Vector3d x =
          EvalTetPoint(skin.mesh, skin.state->x, state.tissues[0].points[i].point);
      const Eigen::Vector3d a = needle.X_WN_start.translation();
      const Eigen::Vector3d z = needle.X_WN_start.linear().col(2);
      ASSERT_LT(((x - a) - (x - a).dot(z) * z).norm(), kLineTol) << "step " << k;
    }
  }
  const TissueCouplingReport& rs = state.tissues[0].report;
  const TissueCouplingReport& rl = state.tissues[1].report;
  EXPECT_EQ(rs.phase, TissuePhase::kExited);
  EXPECT_TRUE(rs.punctured);
  EXPECT_EQ(state.tissues[0].points.back().kind, NeedlePathPoint::Kind::kExit);
  // the needle inside the skin is about its thickness (deformed)
  EXPECT_GT(rs.depth, 0.005);
  EXPECT_LT(rs.depth, 0.02);
  EXPECT_EQ(rl.phase, TissuePhase::kInside);
  EXPECT_GT(rl.depth, 0.005);
  EXPECT_GT(skin_exit_time, 0.0);
  EXPECT_GT(liver_puncture_time, skin_exit_time);
  EXPECT_LT(rs.puncture_time, skin_exit_time);
  EXPECT_EQ(state.tip_tissue, 1);
}

TEST(NeedleInsertionTest, RigidBevelLoadsTheTissueAtTheTip) {
  FemBlock block(Eigen::Vector3i(6, 6, 6), Eigen::Vector3d(kSide, kSide, kSide),
                 Eigen::Vector3d::Zero());
  NeedleCouplingConfig config;
  config.tissues = {MakeTissue("block")};
  config.bevel.enabled = true;
  const NeedleTissueCoupling coupling(config, {&block.mesh});
  NeedleCouplingState state = coupling.MakeState();
  NeedleInsertionStepper stepper(coupling);
  const RigidNeedleModel needle_model{NeedleConfig{}};
  RigidNeedleState needle;
  Eigen::Vector3d base(kSide / 2, kSide / 2, kSide + 1e-3 + needle_model.length());
  ResetRigidNeedle(needle_model, DownwardFlange(base), needle);
  bool loaded = false;
  for (int k = 0; k < 50; ++k) {
    base.z() -= kStepAdvance;
    const NeedleStepReport r =
        stepper.StepRigid(needle_model, needle, DownwardFlange(base), {block.body.get()}, state);
    const Eigen::Vector3d total = block.state->external_forces.rowwise().sum();
    if (r.bevel_active) {
      // -Q y_B on the tissue, y_B = the flange y axis turned down: -y_W for this flange
      loaded = true;
      const double q = coupling.get_bevel_loads().q;
      const Eigen::Vector3d y_B = needle.X_WN_start.linear().col(1);
      EXPECT_TRUE(total.isApprox(-q * y_B, 1e-12)) << total.transpose();
    } else {
      EXPECT_LT(total.norm(), 1e-15);
    }
  }
  EXPECT_TRUE(loaded);
}

}  // namespace
}  // namespace nsim
