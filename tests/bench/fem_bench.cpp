// FEM engine benchmarks on the liver meshes (configs/meshes/liver_{700,2660,10000}.msh, and
// liver_30000.msh from scripts/make_meshes.sh --large when NSIM_LARGE_MESH_DIR names its folder):
// one implicit step with the diaphragm nodes prescribed (breathing), the inferior tip fixed,
// gravity, after 1 s of simulated breathing (moderate deformation). Measure on one core:
//   OPENBLAS_NUM_THREADS=1 taskset -c 0 fem_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// Names: what/size (#nodes). LiverStep = fast path (PCG + cached warped factor) with the
// refresh inside the step that asks for it (background_refactor = false),
// LiverStepBackgroundRefresh = same with the deterministic background refresh (background_refactor:
// factorized on a worker, adopted refactor_adopt_delay = 3 steps later),
// LiverStepRefactorEveryStep = direct CHOLMOD path (the naive baseline), Refactorize = one
// numeric factorization, Solve = one solve with a factor (the floor of any step),
// ApplyInverse40 = A^-1 on 40 sparse constraint columns.
// LiverStepSequence/<refresh>/size: the distribution of the step time over a sequence of 600
// breathing steps from rest (12 s, 3 cycles; 200 for the direct path), wall clock, one sequence per
// repetition: counters p50_ms, p90_ms, p99_ms, max_ms (tests/bench/step_times.h), the steps
// that adopt a background factor (swap_step_ms) or hand one to the worker (request_step_ms).
// ...WhenReady: each refresh adopted at the first step that finds it done (FactorAdoption::
// kWhenReady, realtime runs), never waiting; adoption_lag = steps from request to adoption.
// ...ElementThreads2: the element passes split over two threads (FemConfig::element_threads);
// the 10000-node sequences are 100 steps.
// The worker needs a second core to be off the critical path: on one core (taskset -c 1) it
// time-shares with the steps it overlaps.

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "common/fem/cholmod_factor.h"
#include "common/fem/corotational.h"
#include "common/fem/single_precision_factor.h"
#include "common/fem/fem_solver.h"
#include "common/mesh/gmsh_reader.h"
#include "tests/bench/step_times.h"

namespace nsim {
namespace {

struct LiverScene {
  TetMesh mesh;
  FemBoundary boundary;
};

// superior 15 % of the height: diaphragm (prescribed); inferior 5 %: fixed
LiverScene MakeScene(const std::string& path) {
  LiverScene scene;
  scene.mesh = ReadGmshMesh(path);
  const double z_min = scene.mesh.X.row(2).minCoeff(), z_max = scene.mesh.X.row(2).maxCoeff();
  const double height = z_max - z_min;
  for (int i = 0; i < scene.mesh.num_nodes(); ++i) {
    const double z = scene.mesh.X(2, i);
    if (z > z_max - 0.15 * height) scene.boundary.prescribed_nodes.push_back(i);
    else if (z < z_min + 0.05 * height) scene.boundary.fixed_nodes.push_back(i);
  }
  return scene;
}

// The committed meshes; the ~30000-node one is generated, not committed (6.5 MB):
// scripts/make_meshes.sh --large DIR writes it, and bench.sh passes DIR as NSIM_LARGE_MESH_DIR.
constexpr int kLargeMesh = 30000;
std::string MeshPath(int nodes) {
  if (nodes == kLargeMesh) {
    const char* dir = std::getenv("NSIM_LARGE_MESH_DIR");
    return std::string(dir ? dir : "") + "/liver_" + std::to_string(nodes) + ".msh";
  }
  return std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_" + std::to_string(nodes) + ".msh";
}

// breathing: 12 mm superior-inferior, 4 mm antero-posterior, 4 s period, cos^2 shape
void Breathe(const FemModel& model, FemState& state, double t) {
  const double phase = std::pow(std::cos(M_PI * t / 4.0), 2);
  const Eigen::Vector3d offset(0.0, -0.004 * (1 - phase), -0.012 * (1 - phase));
  const auto& nodes = model.get_prescribed_nodes();
  for (size_t k = 0; k < nodes.size(); ++k)
    state.prescribed_positions.col(k) = model.get_rest_positions().col(nodes[k]) + offset;
}

struct Fixture {
  std::unique_ptr<FemModel> model;
  std::unique_ptr<FemSolver> solver;
  std::unique_ptr<FemState> state;

  Fixture(int nodes, FemLinearSolver kind, bool background, int adopt_delay = 3,
          int warm_up_steps = 50, int element_threads = 1,
          FactorAdoption adoption = FactorAdoption::kScheduled) {
    const LiverScene scene = MakeScene(MeshPath(nodes));
    FemConfig config;  // liver: E 5.5 kPa, nu 0.45, rho 1060, h 20 ms
    config.rayleigh_mass = 0.1;
    config.rayleigh_stiffness = 0.01;
    config.linear_solver = kind;
    config.background_refactor = background;
    config.refactor_adopt_delay = adopt_delay;
    config.element_threads = element_threads;
    config.refactor_adoption = adoption;
    model = std::make_unique<FemModel>(scene.mesh, config, scene.boundary);
    solver = std::make_unique<FemSolver>(*model);
    state = std::make_unique<FemState>(*model);
    for (int step = 0; step < warm_up_steps; ++step) Step();  // 1 s of breathing
  }
  FemStepStats Step() {
    Breathe(*model, *state, state->time + model->get_config().time_step);
    return solver->Step(*state);
  }
};

void RunSteps(benchmark::State& bench, int nodes, FemLinearSolver kind, bool background) {
  Fixture fixture(nodes, kind, background);
  double iterations = 0, refactorizations = 0, swaps = 0, steps = 0;
  for (auto _ : bench) {
    const FemStepStats stats = fixture.Step();
    iterations += stats.cg_iterations;
    refactorizations += stats.refactorized;
    swaps += stats.factor_swapped;
    steps += 1;
  }
  bench.counters["cg_iterations"] = iterations / steps;
  bench.counters["refactor_per_step"] = refactorizations / steps;
  bench.counters["bg_swaps_per_step"] = swaps / steps;
  bench.counters["dofs"] = 3.0 * fixture.model->num_free_nodes();
}

// the step-time distribution over a long breathing sequence (Iterations = steps)
void RunSequence(benchmark::State& bench, int nodes, FemLinearSolver kind, bool background,
                 int adopt_delay = 3, int element_threads = 1,
                 FactorAdoption adoption = FactorAdoption::kScheduled) {
  // from rest: the first second needs the refreshes (~5); after it the warm-started PCG needs
  // ~2.5 iterations a step and the breathing alone asks for none
  Fixture fixture(nodes, kind, background, adopt_delay, 0, element_threads, adoption);
  StepTimes times(static_cast<size_t>(bench.max_iterations));
  std::vector<double> swap_ms, request_ms;
  double iterations = 0, refactorizations = 0, swaps = 0, waits = 0, steps = 0, lags = 0;
  for (auto _ : bench) {
    const FemStepStats stats = times.Time([&] { return fixture.Step(); });
    iterations += stats.cg_iterations;
    refactorizations += stats.refactorized;
    swaps += stats.factor_swapped;
    waits += stats.waited_for_worker;
    lags += stats.adoption_lag;
    if (stats.factor_swapped) swap_ms.push_back(times.last());
    if (stats.refresh_requested) request_ms.push_back(times.last());
    steps += 1;
  }
  fixture.solver->WaitForBackgroundFactorization();
  times.Report(bench);
  bench.counters["cg_iterations"] = iterations / steps;
  bench.counters["refactor_per_step"] = refactorizations / steps;
  bench.counters["bg_swaps_per_step"] = swaps / steps;
  bench.counters["waits_per_swap"] = swaps > 0 ? waits / swaps : 0.0;
  bench.counters["adoption_lag"] = swaps > 0 ? lags / swaps : 0.0;  // steps, request to adoption
  bench.counters["swap_step_ms"] = StepTimes::Percentile(swap_ms, 0.5);
  bench.counters["request_step_ms"] = StepTimes::Percentile(request_ms, 0.5);
}

// the factor's cost hardly depends on the deformation: the large mesh skips the second of
// breathing (50 refactorizations of ~1 s each with the direct solver)
int DirectWarmUp(int nodes) { return nodes >= kLargeMesh ? 1 : 50; }

void Refactorize(benchmark::State& bench, int nodes) {
  Fixture fixture(nodes, FemLinearSolver::kDirect, false, 3, DirectWarmUp(nodes));
  const Eigen::SparseMatrix<double> A = fixture.solver->CalcSystemMatrix();
  CholmodFactor factor;
  factor.Analyze(A);
  for (auto _ : bench) benchmark::DoNotOptimize(factor.Factorize(A));
  bench.counters["nnz_A"] = static_cast<double>(A.nonZeros());
  bench.counters["nnz_L"] = factor.get_factor_nnz();
  bench.counters["gflop"] = factor.get_factor_flops() * 1e-9;
}

// one solve with a factor of A (CHOLMOD, double: the floor of a step), or with its
// single-precision copy (the PCG preconditioner's solve)
void Solve(benchmark::State& bench, int nodes, bool single_precision) {
  Fixture fixture(nodes, FemLinearSolver::kDirect, false, 3, DirectWarmUp(nodes));
  const Eigen::SparseMatrix<double> A = fixture.solver->CalcSystemMatrix();
  CholmodFactor factor;
  factor.Analyze(A);
  factor.Factorize(A);
  SinglePrecisionFactor single;
  if (single_precision) single.Assign(factor.supernodal_view());
  const Eigen::VectorXd b = Eigen::VectorXd::Random(A.rows());
  Eigen::VectorXd x(A.rows()), reference(A.rows());
  factor.Solve(b, reference);
  for (auto _ : bench) {
    if (single_precision) single.Solve(b, x);
    else factor.Solve(b, x);
    benchmark::DoNotOptimize(x.data());
  }
  if (single_precision)
    bench.counters["relative_difference"] = (x - reference).norm() / reference.norm();
}

// X = A^-1 B for k right-hand sides at once (CholmodFactor::Solve: CHOLMOD for one, the
// supernodal solve of supernodal_solve.h for several), against k solves of one column each:
// the compliance columns of the constraint points (3 per new node) are such solves
// unit: B holds the unit columns of k / 3 nodes (a constraint point's compliance columns; the
// nodes spread over the mesh), else random dense columns
void SolveColumns(benchmark::State& bench, int nodes, int k, bool one_by_one, bool unit) {
  Fixture fixture(nodes, FemLinearSolver::kDirect, false, 3, DirectWarmUp(nodes));
  const Eigen::SparseMatrix<double> A = fixture.solver->CalcSystemMatrix();
  CholmodFactor factor;
  factor.Analyze(A);
  factor.Factorize(A);
  Eigen::MatrixXd B = Eigen::MatrixXd::Random(A.rows(), k);
  if (unit) {
    B.setZero();
    for (int c = 0; c < k; ++c) B(3 * ((c / 3 + 1) * (A.rows() / 3) / (k / 3 + 1)) + c % 3, c) = 1.0;
  }
  Eigen::MatrixXd X(A.rows(), k);
  for (auto _ : bench) {
    if (one_by_one)
      for (int c = 0; c < k; ++c) factor.Solve(B.col(c), X.col(c));
    else
      factor.Solve(B, X);
    benchmark::DoNotOptimize(X.data());
  }
  bench.counters["residual"] = (A * X - B).norm() / B.norm();
  bench.counters["ms_per_column"] = benchmark::Counter(
      k, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// A^-1 H^T for 40 constraint rows, each on the 4 nodes of one tet (barycentric point)
void ApplyInverse40(benchmark::State& bench, int nodes, FemInverse which) {
  Fixture fixture(nodes, FemLinearSolver::kPcgCachedFactor, false);
  const FemModel& model = *fixture.model;
  Eigen::SparseMatrix<double> Ht(3 * model.num_nodes(), 40);
  for (int c = 0; c < 40; ++c) {
    const Eigen::Vector4i& t = model.get_mesh().tets[(c * 7919) % model.num_tets()];
    for (int a = 0; a < 4; ++a) Ht.insert(3 * t[a] + c % 3, c) = 0.25;
  }
  Ht.makeCompressed();
  Breathe(model, *fixture.state, fixture.state->time + model.get_config().time_step);
  fixture.solver->BeginStep(*fixture.state);
  Eigen::MatrixXd out;
  for (auto _ : bench) {
    fixture.solver->ApplyInverse(Ht, out, which);
    benchmark::DoNotOptimize(out.data());
  }
}

// PolarRotation/{One,Batch}: the polar rotations of the 2660-node liver's elements after 1 s
// of breathing (its deformation gradients), one CalcPolarRotation call each or
// CalcPolarRotations on all; time for all of them (iterations_per_element: of the Newton
// iteration, one matrix at a time)
void PolarRotation(benchmark::State& bench, bool batch) {
  const Fixture fixture(2660, FemLinearSolver::kPcgCachedFactor, false);
  const FemModel& model = *fixture.model;
  const int count = model.num_tets();
  std::vector<Eigen::Matrix3d> F(count), R(count);
  std::vector<char> used_svd(count);
  for (int e = 0; e < count; ++e) {
    Matrix34d xe;
    for (int a = 0; a < 4; ++a) xe.col(a) = fixture.state->x.col(model.get_mesh().tets[e][a]);
    F[e] = CalcDeformationGradient(model.get_rest_shapes()[e], xe);
  }
  for (auto _ : bench) {
    if (batch) {
      CalcPolarRotations(F.data(), R.data(), reinterpret_cast<bool*>(used_svd.data()), count);
    } else {
      for (int k = 0; k < count; ++k) R[k] = CalcPolarRotation(F[k]);
    }
    benchmark::DoNotOptimize(R.data());
  }
}

}  // namespace
}  // namespace nsim

int main(int argc, char** argv) {
  using namespace nsim;
  const char* threads = std::getenv("OPENBLAS_NUM_THREADS");
  benchmark::AddCustomContext("OPENBLAS_NUM_THREADS", threads ? threads : "unset (all cores)");
  for (bool batch : {false, true})
    benchmark::RegisterBenchmark(batch ? "PolarRotation/Batch" : "PolarRotation/One",
                                 [batch](benchmark::State& s) { PolarRotation(s, batch); })
        ->Unit(benchmark::kMicrosecond);
  for (int nodes : {700, 2660, 10000, kLargeMesh}) {
    if (!std::ifstream(MeshPath(nodes))) continue;
    const std::string n = std::to_string(nodes);
    // the large mesh is the scaling point only: the step, one solve, one factorization
    const bool scaling_only = nodes == kLargeMesh;
    benchmark::RegisterBenchmark(("LiverStep/" + n).c_str(), [nodes](benchmark::State& s) {
      RunSteps(s, nodes, FemLinearSolver::kPcgCachedFactor, false);
    })->Unit(benchmark::kMillisecond);
    if (!scaling_only)
      benchmark::RegisterBenchmark(("LiverStepBackgroundRefresh/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSteps(s, nodes, FemLinearSolver::kPcgCachedFactor, true);
                                   })->Unit(benchmark::kMillisecond);
    if (nodes == 2660) {
      benchmark::RegisterBenchmark(("LiverStepSequence/InStepRefresh/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, false);
                                   })
          ->Unit(benchmark::kMillisecond)->Iterations(600)->UseRealTime();
      for (int delay : {3, 1}) {
        benchmark::RegisterBenchmark(
            ("LiverStepSequence/BackgroundRefresh" +
             std::string(delay == 3 ? "" : "Delay" + std::to_string(delay)) + "/" + n)
                .c_str(),
            [nodes, delay](benchmark::State& s) {
              RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, true, delay);
            })
            ->Unit(benchmark::kMillisecond)->Iterations(600)->UseRealTime();
      }
      benchmark::RegisterBenchmark(("LiverStepSequence/BackgroundRefreshWhenReady/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, true,
                                                 3, 1, FactorAdoption::kWhenReady);
                                   })
          ->Unit(benchmark::kMillisecond)->Iterations(600)->UseRealTime();
      benchmark::RegisterBenchmark(("LiverStepSequence/BackgroundRefreshElementThreads2/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, true, 3, 2);
                                   })
          ->Unit(benchmark::kMillisecond)->Iterations(600)->UseRealTime();
      benchmark::RegisterBenchmark(("LiverStepSequence/RefactorEveryStep/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSequence(s, nodes, FemLinearSolver::kDirect, false);
                                   })
          ->Unit(benchmark::kMillisecond)->Iterations(200)->UseRealTime();
    }
    if (nodes == 10000) {
      // 100 steps (2 s) from rest: the 10000-node step serial and with the element passes on two
      // threads (a second core; on one core the helper time-shares)
      for (int threads : {1, 2}) {
        benchmark::RegisterBenchmark(
            ("LiverStepSequence/BackgroundRefresh" +
             std::string(threads == 1 ? "" : "ElementThreads2") + "/" + n).c_str(),
            [nodes, threads](benchmark::State& s) {
              RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, true, 3, threads);
            })
            ->Unit(benchmark::kMillisecond)->Iterations(100)->UseRealTime();
      }
      benchmark::RegisterBenchmark(("LiverStepSequence/BackgroundRefreshWhenReady/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSequence(s, nodes, FemLinearSolver::kPcgCachedFactor, true,
                                                 3, 1, FactorAdoption::kWhenReady);
                                   })
          ->Unit(benchmark::kMillisecond)->Iterations(100)->UseRealTime();
    }
    if (nodes <= 2660) {
      benchmark::RegisterBenchmark(("LiverStepRefactorEveryStep/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     RunSteps(s, nodes, FemLinearSolver::kDirect, false);
                                   })->Unit(benchmark::kMillisecond);
    }
    benchmark::RegisterBenchmark(("Refactorize/" + n).c_str(), [nodes](benchmark::State& s) {
      Refactorize(s, nodes);
    })->Unit(benchmark::kMillisecond);
    for (bool single : {false, true})
      benchmark::RegisterBenchmark(((single ? "SolveSingle/" : "Solve/") + n).c_str(),
                                   [nodes, single](benchmark::State& s) { Solve(s, nodes, single); })
          ->Unit(benchmark::kMillisecond);
    if (!scaling_only)
      for (int k : {1, 3, 6, 12})
        for (bool one_by_one : {false, true})
          for (bool unit : {false, true}) {
            if ((k == 1 && one_by_one) || (unit && k % 3 != 0)) continue;
            const std::string name = std::string(unit ? "SolveNodeColumns" : "SolveColumns") +
                                     (one_by_one ? "OneByOne/" : "/") + n + "/" + std::to_string(k);
            benchmark::RegisterBenchmark(name.c_str(), [nodes, k, one_by_one, unit](benchmark::State& s) {
              SolveColumns(s, nodes, k, one_by_one, unit);
            })->Unit(benchmark::kMillisecond);
          }
    if (!scaling_only)
      benchmark::RegisterBenchmark(("ApplyInverse40CachedFactor/" + n).c_str(),
                                   [nodes](benchmark::State& s) {
                                     ApplyInverse40(s, nodes, FemInverse::kCachedFactor);
                                   })->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
