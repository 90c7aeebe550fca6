// FemInverse::kRestFactor (the FemSolver's own construction-time factor of A_0) against
// RestComplianceBody (a second factorization of the same A_0): the compliance columns must be
// bit-identical at every step, whatever refreshes of the cached factor happen meanwhile.
#include "common/scene/rest_compliance_body.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/scene/patient_scene.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

void CompareOverSteps(bool background) {
  const DirectScenario s = testing::LoadCoarseScenario();
  const PatientSceneModel scene(s.scene, s.liver_mesh, s.skin_mesh);
  FemConfig config = scene.liver().get_config();
  config.background_refactor = background;
  config.refactor_adopt_delay = 2;
  config.refactor_iteration_threshold = 1;  // refresh often: the cached factor leaves A_0 early
  const FemModel model(scene.liver().get_mesh(), config,
                       {scene.liver().get_fixed_nodes(), scene.liver().get_prescribed_nodes()});
  FemSolver solver(model);
  FemState state(model);
  FemConstraintBody body(solver, state, FemInverse::kRestFactor);
  RestComplianceBody reference(body, solver);
  // forces on 4 surface nodes and one barycentric point (3 columns each)
  const int n = model.num_nodes();
  Eigen::SparseMatrix<double> forces(3 * n, 15);
  const std::vector<int>& nodes = scene.contact_nodes();
  for (int c = 0; c < 12; ++c) forces.insert(3 * nodes[(c / 3) * 37 % nodes.size()] + c % 3, c) = 1.0;
  const Eigen::Vector4i& tet = model.get_mesh().tets[model.num_tets() / 2];
  const Eigen::Vector4d bary(0.1, 0.2, 0.3, 0.4);
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 4; ++a) forces.insert(3 * tet[a] + c, 12 + c) = bary[a];
  forces.makeCompressed();
  const std::uint64_t version = body.compliance_version();
  const std::uint64_t factor_at_start = solver.get_factor_version();
  Eigen::MatrixXd ours, theirs;
  const Eigen::Matrix3Xd& X = model.get_rest_positions();
  for (int step = 0; step < 60; ++step) {
    const double t = (step + 1) * config.time_step;
    const Eigen::Vector3d d(0.0, 0.004 * std::sin(3.0 * t), 0.012 * std::sin(2.0 * t));
    for (size_t k = 0; k < model.get_prescribed_nodes().size(); ++k)
      state.prescribed_positions.col(k) = X.col(model.get_prescribed_nodes()[k]) + d;
    body.BeginStep();
    body.ApplyCompliance(forces, ours);
    reference.ApplyCompliance(forces, theirs);
    ASSERT_EQ(ours.rows(), theirs.rows());
    ASSERT_EQ(ours.cols(), theirs.cols());
    ASSERT_EQ((ours - theirs).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
    EXPECT_EQ(body.compliance_version(), version);
    body.EndStep();
  }
  EXPECT_NE(solver.get_factor_version(), factor_at_start);  // the cached factor was refreshed
  EXPECT_GT(ours.norm(), 0.0);
}

TEST(RestComplianceBodyTest, RestFactorColumnsAreBitIdenticalInStepRefresh) {
  CompareOverSteps(false);
}

TEST(RestComplianceBodyTest, RestFactorColumnsAreBitIdenticalBackgroundRefresh) {
  CompareOverSteps(true);
}

}  // namespace
}  // namespace nsim
