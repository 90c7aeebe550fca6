// FemSolver steps with Eigen's allocation guard (built with EIGEN_RUNTIME_NO_MALLOC, the library
// sources compiled into this test): any Eigen heap allocation inside a step aborts.
// Covered: every Eigen object in BeginStep, CommitStep and ApplyInverse (same column count as
// before) on the PCG and direct paths. Not covered: CHOLMOD's own malloc calls (cholmod_solve2
// reuses its workspaces after the first call of a given column count; cholmod_factorize uses
// its Common workspace, allocated on the first factorization).

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "common/fem/fem_solver.h"

namespace nsim {
namespace {

void RunGuarded(FemLinearSolver kind, bool background_refactor = false) {
  const TetMesh mesh = MakeBoxTetMesh({6, 5, 5}, {0.1, 0.08, 0.06});
  std::vector<int> bottom, top;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (mesh.X(2, i) == 0.0) bottom.push_back(i);
    if (mesh.X(2, i) == 0.06) top.push_back(i);
  }
  FemConfig config;
  config.linear_solver = kind;
  config.refactor_iteration_threshold = 2;  // exercise synchronous refactorization too
  config.background_refactor = background_refactor;  // or the adoption of background factors
  const FemModel model(mesh, config, {bottom, top});
  FemSolver solver(model);
  FemState state(model);
  const int n = model.num_nodes();
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(3 * n, 4), out;
  for (int c = 0; c < 4; ++c) rhs(3 * model.get_free_nodes()[5 * c] + 2, c) = 1.0;
  auto step = [&](int k) {
    for (size_t j = 0; j < top.size(); ++j)
      state.prescribed_positions.col(j) =
          Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitY()) * model.get_rest_positions().col(top[j]);
    solver.BeginStep(state);
    solver.ApplyInverse(rhs, out, FemInverse::kCachedFactor);
    solver.ApplyInverse(rhs, out, FemInverse::kCurrentSystem);
    solver.CommitStep(state);
  };
  step(0);  // warm-up: sizes the ApplyInverse buffers and CHOLMOD workspaces
  int refactorized = 0, swapped = 0;
  Eigen::internal::set_is_malloc_allowed(false);
  for (int k = 1; k <= 10; ++k) {
    step(k);
    refactorized += solver.get_last_stats().refactorized;
    swapped += solver.get_last_stats().factor_swapped;
  }
  Eigen::internal::set_is_malloc_allowed(true);
  EXPECT_TRUE(state.x.allFinite());
  if (background_refactor) {
    EXPECT_EQ(refactorized, 0);  // no factorization on this thread: requests and adoptions only
    EXPECT_GT(swapped, 0);
  } else {
    EXPECT_GT(refactorized, 0);
  }
}

TEST(FemSolverNoMallocTest, PcgStepDoesNotAllocate) { RunGuarded(FemLinearSolver::kPcgCachedFactor); }
TEST(FemSolverNoMallocTest, PcgStepWithBackgroundRefreshDoesNotAllocate) {
  RunGuarded(FemLinearSolver::kPcgCachedFactor, true);
}
TEST(FemSolverNoMallocTest, DirectStepDoesNotAllocate) { RunGuarded(FemLinearSolver::kDirect); }

}  // namespace
}  // namespace nsim
