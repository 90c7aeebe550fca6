// Cost of one implicit FEM step with Lagrangian constraints (DESIGN.md "Speed"): a 2660-node
// liver, 13 tissue points along a straight needle path held by 3 bilateral rows each plus one
// axial row at the tip (40 rows), direct LDLT resolution, correction through the FEM solver.
// Run single-threaded: OPENBLAS_NUM_THREADS=1 constraints_bench --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <memory>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/fem_body.h"
#include "common/fem/fem_model.h"
#include "common/mesh/gmsh_reader.h"
#include "common/mesh/point_locator.h"
#include "common/mesh/tet_mesh.h"

namespace nsim {
namespace {

constexpr int kNeedlePoints = 13;

// the committed liver mesh (metres)
TetMesh LoadLiver() {
  return ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_2660.msh");
}

// the scene: liver fixed on its lowest-x tenth, no gravity, a needle along x through the centre
struct Scene {
  TetMesh mesh;
  std::unique_ptr<FemModel> model;
  std::unique_ptr<FemSolver> fem;
  std::unique_ptr<FemState> state;
  std::unique_ptr<FemConstraintBody> body;
  std::vector<TetPoint> points;
  std::vector<Eigen::Vector3d> rest;  // rest positions of the points (m)
  TetPoint tip_point;                 // 1 cm beyond the last needle point
  Eigen::Vector3d tip_rest;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  ConstraintSolver solver;
  ConstraintSet set;

  Scene() : mesh(LoadLiver()) {
    const Eigen::Vector3d lo = mesh.X.rowwise().minCoeff(), hi = mesh.X.rowwise().maxCoeff();
    FemBoundary boundary;
    for (int i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.X(0, i) < lo.x() + 0.1 * (hi.x() - lo.x())) boundary.fixed_nodes.push_back(i);
    FemConfig config;  // liver defaults: E 5.5 kPa, nu 0.45, 1060 kg/m^3, h 0.02 s, PCG
    config.rayleigh_mass = 1.0;
    // as in the patient scene, the organs around the liver carry its weight: a 21 cm liver of
    // 5.5 kPa held by one end would sag by centimetres and refactorize at every step
    config.gravity.setZero();
    // with constraints a factor refresh also invalidates the cached compliance columns of the
    // held points (42 solves, ~20 ms), so refresh less eagerly than the free step's best (3):
    // measured 40 % of steps refreshing at 3 (33 ms a step), none at 5 (8.1 ms a step, CPU)
    config.refactor_iteration_threshold = 5;
    model = std::make_unique<FemModel>(mesh, config, boundary);
    fem = std::make_unique<FemSolver>(*model);
    state = std::make_unique<FemState>(*model);
    body = std::make_unique<FemConstraintBody>(*fem, *state);
    const TetLocator locator(mesh);
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const double length = 0.5 * (hi.x() - lo.x());
    for (int k = 0; k < kNeedlePoints; ++k) {
      const Eigen::Vector3d p =
          centre + axis * length * (-0.5 + static_cast<double>(k) / (kNeedlePoints - 1));
      points.push_back(locator.LocateClosest(p));
      rest.push_back(EvalTetPoint(mesh, mesh.X, points.back()));
    }
    tip_point = locator.LocateClosest(rest.back() + 0.01 * axis);
    tip_rest = EvalTetPoint(mesh, mesh.X, tip_point);
  }

  // rows: every needle point held on the needle displaced by 2 mm across (39 rows), plus the
  // tissue ahead of the tip axially (1 row)
  void BuildRows() {
    set.Clear();
    const int b = set.AddBody(*body);
    const Eigen::Vector3d shift(0.0, 0.002, 0.001);
    for (int k = 0; k < kNeedlePoints; ++k) {
      const int p = set.AddBodyPoint(b, mesh.tets[points[k].tet], points[k].bary, k + 1);
      const Eigen::Vector3d goal = rest[k] + shift;
      const int n = set.AddKinematicPoint(goal, goal);
      set.AddBilateral(p, n, Eigen::Matrix3d::Identity());
    }
    // the tissue just ahead of the tip, held axially only (40th row)
    const int tip =
        set.AddBodyPoint(b, mesh.tets[tip_point.tet], tip_point.bary, kNeedlePoints + 1);
    const Eigen::Vector3d goal = tip_rest + shift;
    set.AddBilateral(tip, set.AddKinematicPoint(goal, goal), axis);
  }
};

Scene& GetScene() {
  static Scene scene;
  return scene;
}

// free motion + W for 40 rows + direct solve + correction and commit
void LiverStepWithConstraints(benchmark::State& bench) {
  Scene& s = GetScene();
  ConstraintSolveReport report;
  const int factorizations_before = s.fem->get_factorization_count();
  long solved_columns = 0, steps = 0;
  for (auto _ : bench) {
    s.body->BeginStep();
    s.BuildRows();
    report = s.solver.Solve(s.set);
    solved_columns += s.solver.compliance().stats().num_solved_columns;
    ++steps;
    benchmark::DoNotOptimize(s.state->x.data());
  }
  bench.counters["refactor_per_step"] =
      static_cast<double>(s.fem->get_factorization_count() - factorizations_before) / steps;
  bench.counters["solved_columns_per_step"] = static_cast<double>(solved_columns) / steps;
  bench.counters["rows"] = s.set.num_rows();
  bench.counters["nodes"] = s.mesh.num_nodes();
  bench.counters["regularized"] = report.regularized;
  bench.counters["violation_m"] = report.max_violation;
  bench.counters["cg_iterations"] = s.fem->get_last_stats().cg_iterations;
}
BENCHMARK(LiverStepWithConstraints)
    ->Name("LiverStepWithConstraints/2660/40rows")
    ->Unit(benchmark::kMillisecond);

// the unconstrained step, for reference
void LiverFreeStep(benchmark::State& bench) {
  Scene& s = GetScene();
  for (auto _ : bench) {
    s.body->BeginStep();
    s.body->EndStep();
  }
}
BENCHMARK(LiverFreeStep)->Name("LiverFreeStep/2660")->Unit(benchmark::kMillisecond);

// building W alone: 14 points -> 42 compliance columns (one multi-RHS solve) + the 40 x 40 W
void BuildCompliance(benchmark::State& bench) {
  Scene& s = GetScene();
  s.body->BeginStep();
  s.BuildRows();
  Eigen::MatrixXd W;
  for (auto _ : bench) {
    s.solver.compliance().ClearCache();
    s.solver.compliance().Assemble(s.set, W);
    benchmark::DoNotOptimize(W.data());
  }
  bench.counters["columns"] = s.solver.compliance().stats().num_solved_columns;
  s.body->EndStep();
}
BENCHMARK(BuildCompliance)->Name("BuildCompliance/2660/40rows")->Unit(benchmark::kMillisecond);

// W from cached columns (points persist, same operator): what a perturbation re-solve costs
void BuildComplianceCached(benchmark::State& bench) {
  Scene& s = GetScene();
  s.body->BeginStep();
  s.BuildRows();
  Eigen::MatrixXd W;
  s.solver.compliance().Assemble(s.set, W);
  for (auto _ : bench) {
    s.solver.compliance().Assemble(s.set, W);
    benchmark::DoNotOptimize(W.data());
  }
  bench.counters["columns"] = s.solver.compliance().stats().num_solved_columns;
  s.body->EndStep();
}
BENCHMARK(BuildComplianceCached)
    ->Name("BuildComplianceCached/2660/40rows")
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
