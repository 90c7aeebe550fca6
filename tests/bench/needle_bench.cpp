// Needle benchmarks on the 2660-node liver (configs/meshes/liver_2660.msh): one complete step
// (FEM free motion, needle-tissue rows, friction-aware resolution, correction, coupling update)
// with a rigid needle held 8 cm inside the liver, against the FEM free step alone on the same
// scene. Scene as fem_bench: superior 15 % of the nodes prescribed (at rest here), inferior 5 %
// fixed, gravity, E 5.5 kPa. Measure on one core:
//   OPENBLAS_NUM_THREADS=1 taskset -c 0 needle_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <memory>
#include <string>

#include "common/mesh/gmsh_reader.h"
#include "common/needle/needle_insertion.h"

namespace nsim {
namespace {

struct LiverNeedleScene {
  TetMesh mesh;
  std::unique_ptr<FemModel> model;
  std::unique_ptr<FemSolver> solver;
  std::unique_ptr<FemState> state;
  std::unique_ptr<FemConstraintBody> body;
  std::unique_ptr<RigidNeedleModel> needle_model;
  RigidNeedleState needle;
  std::unique_ptr<NeedleTissueCoupling> coupling;
  NeedleCouplingState coupling_state;
  std::unique_ptr<NeedleInsertionStepper> stepper;
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();

  explicit LiverNeedleScene(double depth) {
    mesh = ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_2660.msh");
    FemBoundary boundary;
    const double z_min = mesh.X.row(2).minCoeff(), z_max = mesh.X.row(2).maxCoeff();
    for (int i = 0; i < mesh.num_nodes(); ++i) {
      const double z = mesh.X(2, i);
      if (z > z_max - 0.15 * (z_max - z_min)) boundary.prescribed_nodes.push_back(i);
      else if (z < z_min + 0.05 * (z_max - z_min)) boundary.fixed_nodes.push_back(i);
    }
    FemConfig config;  // liver: E 5.5 kPa, nu 0.45, rho 1060, h 20 ms, PCG + cached factor
    config.rayleigh_mass = 0.1;
    config.rayleigh_stiffness = 0.01;
    model = std::make_unique<FemModel>(mesh, config, boundary);
    solver = std::make_unique<FemSolver>(*model);
    state = std::make_unique<FemState>(*model);
    body = std::make_unique<FemConstraintBody>(*solver, *state);

    NeedleConfig nc;  // rigid needle of thesis §5.2, 13 cm
    needle_model = std::make_unique<RigidNeedleModel>(nc);
    NeedleCouplingConfig cc;
    TissueCouplingConfig liver;
    liver.name = "liver";
    liver.puncture_force = 0.2;
    liver.friction_coefficient = 0.1;
    liver.point_spacing = 0.013;
    cc.tissues = {liver};
    coupling = std::make_unique<NeedleTissueCoupling>(cc, std::vector<const TetMesh*>{&mesh});
    coupling_state = coupling->MakeState();
    stepper = std::make_unique<NeedleInsertionStepper>(*coupling);

    // from the right side (+x) along -x through the centre of the bounding box
    const double x_max = mesh.X.row(0).maxCoeff();
    X_WF.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
    X_WF.translation() = Eigen::Vector3d(x_max + 2e-3 + nc.length, 0.0, 0.0);
    ResetRigidNeedle(*needle_model, X_WF, needle);
    for (int k = 0; k < 1000 && coupling_state.tissues[0].report.depth < depth; ++k) {
      X_WF.translation().x() -= 1e-3;
      Step();
    }
    for (int k = 0; k < 20; ++k) Step();  // settle
  }
  NeedleStepReport Step() {
    return stepper->StepRigid(*needle_model, needle, X_WF, {body.get()}, coupling_state);
  }
};

void LiverStepWithNeedle(benchmark::State& bench) {
  LiverNeedleScene scene(0.08);
  NeedleStepReport last;
  for (auto _ : bench) last = scene.Step();
  const TissueCouplingReport& r = scene.coupling_state.tissues[0].report;
  bench.counters["depth_mm"] = r.depth * 1e3;
  bench.counters["points"] = r.num_points;
  bench.counters["rows"] = last.num_rows;
  bench.counters["cg_iterations"] = scene.solver->get_last_stats().cg_iterations;
}
BENCHMARK(LiverStepWithNeedle)->Name("LiverStepWithNeedle/2660/8cm")->Unit(benchmark::kMillisecond);

void LiverFreeStepSameScene(benchmark::State& bench) {
  LiverNeedleScene scene(0.0);
  for (auto _ : bench) {
    scene.body->BeginStep();
    scene.body->EndStep();
  }
}
BENCHMARK(LiverFreeStepSameScene)->Name("LiverFreeStep/2660")->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
