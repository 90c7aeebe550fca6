// Cost of one control step of the inverse simulation (DESIGN.md "Speed"): the 2660-node liver
// registered to 5 markers with the rigid needle ~3 cm inside it, compared with one plain model
// step (the same simulation step without the Jacobian). Target: control step <= 1.5x plain step.
// The *Flexible cases: the same with the model's needle a 20-element steel beam
// (inverse.needle: flexible, E 200 GPa) instead of the kinematic rigid needle.
// BM_ControlStepScenario: the controller as the default scenario configures it
// (configs/scenarios/liver_breathing.yaml: the 2001-node model meshed apart from the patient's
// liver, its solver settings, constraint compliance, path and law, 12 perturbations), the
// needle ~3 cm into the model's liver: the "control step" goal.
// BM_ControlStepScenarioWithoutLoad: the same without the liver's load objective
// (controller.liver_load 0: the thesis's objectives), for its cost.
// BM_ControlStepScenarioBreathing: the same controller, but each step's input moves as in the
// final phase of a run: the markers and the flange translated by the scenario's breathing
// displacement at that step's time (50 Hz frames), so the model's solves start from a moving
// state instead of settling at rest under a fixed input (docs/performance.md, "The control
// step with the markers breathing").
// The control-step benchmarks also report the distribution of their steps (p50_ms, p90_ms,
// p99_ms, max_ms; tests/bench/step_times.h) over each repetition's iterations.
// Run single-threaded: OPENBLAS_NUM_THREADS=1 steering_bench --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <functional>
#include <memory>
#include <string>

#include "common/breathing/breathing.h"
#include "common/mesh/gmsh_reader.h"
#include "common/robot/iiwa14_ik.h"
#include "common/steering/steering_controller.h"
#include "inverse_sim/scenario_loader.h"
#include "tests/bench/step_times.h"
#include "tests/steering/steering_test_scene.h"

namespace nsim {
namespace {

constexpr int kInsertionSteps = 25;  // 2 mm a step: ~3 cm into the liver
constexpr double kAdvance = 0.002;   // m
constexpr double kFramePeriod = 0.02;  // s: the scenarios' 50 Hz

struct Setup {
  explicit Setup(bool flexible = false) {
    if (!flexible) return;
    model.needle_kind = ModelNeedleKind::kFlexible;
    model.flexible.needle.young_modulus = 200e9;
  }
  TetMesh mesh = steering_test::LoadLiver("liver_2660");
  InverseModelConfig model = [] {
    InverseModelConfig c = steering_test::MakeModelConfig();
    c.liver.linear_solver = FemLinearSolver::kPcgCachedFactor;
    return c;
  }();
  SteeringPathConfig path = steering_test::MakePathConfig();
  Eigen::Isometry3d X_WF0 = SteeringSimulation::CalcStartFlangePose(model.needle, path);
  Eigen::Vector3d dir = (path.target_W - path.entry_W).normalized();

  Eigen::Isometry3d Pose(int step) const {
    Eigen::Isometry3d X = X_WF0;
    X.translation() += kAdvance * step * dir;
    return X;
  }
};

void RunPlainStep(benchmark::State& state, bool flexible) {
  Setup s(flexible);
  SteeringSimulation sim(s.model, s.path, s.mesh, s.X_WF0);
  for (int i = 1; i <= kInsertionSteps; ++i) sim.Step(s.model.markers_W, s.Pose(i));
  const Eigen::Isometry3d X = s.Pose(kInsertionSteps);
  for (auto _ : state) sim.Step(s.model.markers_W, X);
  state.counters["rows"] = sim.liver_coupling().points.size();
}
void BM_PlainStep(benchmark::State& state) { RunPlainStep(state, false); }
void BM_PlainStepFlexible(benchmark::State& state) { RunPlainStep(state, true); }

// the timed loop of the control-step benchmarks: the same input every iteration, or the one
// `advance` makes before each step (k = 0, 1, ...; not timed); the counters are the
// Jacobian's and the model step's shares (ms), the model liver's PCG iterations a step and
// the constraint rows
void TimeControlSteps(benchmark::State& state, SteeringController& controller,
                      SteeringInput input,
                      const std::function<void(int, SteeringInput&)>& advance = nullptr) {
  double jacobian = 0.0, simulation = 0.0, cg_iterations = 0.0;
  int rows = 0;
  int k = 0;
  StepTimes times(static_cast<size_t>(state.max_iterations));
  for (auto _ : state) {
    if (advance) {
      state.PauseTiming();
      advance(k++, input);
      state.ResumeTiming();
    }
    const SteeringOutput out = times.Time([&] { return controller.Update(input); });
    cg_iterations += out.model.fem.cg_iterations;
    jacobian += out.timings.jacobian;
    simulation += out.timings.simulation;
    rows = out.model.num_rows;
  }
  times.Report(state);  // the control steps' distribution: p50_ms, p99_ms, ...
  state.counters["jacobian_ms"] = 1e3 * jacobian / state.iterations();
  state.counters["model_step_ms"] = 1e3 * simulation / state.iterations();
  state.counters["cg_iterations"] = cg_iterations / state.iterations();  // the model liver's PCG
  state.counters["rows"] = rows;
}

void RunControlStep(benchmark::State& state, SteeringDof dof, bool flexible = false) {
  Setup s(flexible);
  SteeringControlConfig control;
  control.dof = dof;
  control.iiwa.X_WB.translation() = Eigen::Vector3d(0.0, 0.75, -0.3);
  SteeringController controller(s.model, s.path, control, s.mesh, s.X_WF0);
  SteeringInput input;
  input.p_WM = s.model.markers_W;
  const Iiwa14InverseKinematics ik(controller.iiwa(), Iiwa14IkConfig());
  Vector7d q = controller.iiwa().CalcMidRange();
  for (int i = 1; i <= kInsertionSteps; ++i) {
    input.X_WE = s.Pose(i);
    if (dof == SteeringDof::kJoint7) {
      // the joints of the insertion pose (the model follows the flange pose they give)
      q = ik.Solve(input.X_WE, q).q;
      input.q = q;
    }
    controller.Update(input);
  }
  TimeControlSteps(state, controller, input);
}

// one frozen-step solve of the Jacobian (SteeringSimulation::EvaluateAt at a perturbed flange
// pose, alternating between +-1 mm along x), with the needle ~3 cm in the liver (bilateral rows
// only) or pressing on its surface before the puncture (a unilateral contact: the active set)
void RunSnapshotSolve(benchmark::State& state, bool contact) {
  Setup s;
  SteeringSimulation sim(s.model, s.path, s.mesh, s.X_WF0);
  int step = 0;
  if (contact) {
    while (sim.liver_coupling().phase != TissuePhase::kContact && step < kInsertionSteps)
      sim.Step(s.model.markers_W, s.Pose(++step));
    if (sim.liver_coupling().phase != TissuePhase::kContact) {
      state.SkipWithError("the needle never pressed on the liver");
      return;
    }
  } else {
    while (step < kInsertionSteps) sim.Step(s.model.markers_W, s.Pose(++step));
  }
  Eigen::Isometry3d X[2] = {s.Pose(step), s.Pose(step)};
  X[0].translation().x() += 1e-3;
  X[1].translation().x() -= 1e-3;
  SnapshotWorkspace ws;
  SteeringEvaluation eval;
  int k = 0;
  for (auto _ : state) {
    eval = sim.EvaluateAt(X[k], ws);
    k = 1 - k;
    benchmark::DoNotOptimize(eval.p_WPath.data());
  }
  state.counters["rows"] = eval.solve.num_rows;
  state.counters["converged"] = eval.solve.converged;
  state.counters["iterations"] = eval.solve.iterations;
}
void BM_SnapshotSolve(benchmark::State& state) { RunSnapshotSolve(state, false); }
void BM_SnapshotSolveContact(benchmark::State& state) { RunSnapshotSolve(state, true); }

// the default scenario's controller: the pose advanced along its plan from the start pose, 2 mm
// a step, until the tip is kScenarioDepth past the entry, the markers at rest
void RunControlStepScenario(benchmark::State& state, bool liver_load, bool breathing = false) {
  constexpr double kScenarioDepth = 0.045;  // the liver starts ~1.5 cm below the skin entry
  InverseScenario scenario = LoadInverseScenario(
      std::string(NSIM_SOURCE_DIR) + "/configs/scenarios/liver_breathing.yaml");
  if (!liver_load) scenario.loop.control.liver_load = 0.0;
  const ControllerLoopConfig& loop = scenario.loop;
  const TetMesh mesh = ReadGmshMesh(scenario.mesh_path);
  const Eigen::Isometry3d X_WF0 = SteeringSimulation::CalcStartFlangePose(loop.model.needle, loop.path);
  SteeringController controller(loop.model, loop.path, loop.control, mesh, X_WF0);
  const Eigen::Vector3d dir = (loop.path.target_W - loop.path.entry_W).normalized();
  const int steps = static_cast<int>((loop.path.approach_distance + kScenarioDepth) / kAdvance);
  SteeringInput input;
  input.p_WM = loop.model.markers_W;
  input.X_WE = X_WF0;
  TissuePhase phase = TissuePhase::kOutside;
  for (int i = 1; i <= steps; ++i) {
    input.X_WE.translation() = X_WF0.translation() + kAdvance * i * dir;
    phase = controller.Update(input).model.liver_phase;
  }
  if (phase != TissuePhase::kInside) {
    state.SkipWithError("the model's needle is not in its liver after the insertion");
    return;
  }
  if (breathing) {
    // BreathingConfig's defaults are the default scenario's `breathing:` (4 s, 12 mm
    // superior-inferior peak to peak), from the exhale rest, one frame a step
    const BreathingModel motion{BreathingConfig{}};
    const SteeringInput rest = input;
    TimeControlSteps(state, controller, input, [&](int k, SteeringInput& in) {
      const Eigen::Vector3d d = motion.CalcDisplacement(kFramePeriod * k);
      for (size_t m = 0; m < in.p_WM.size(); ++m) in.p_WM[m] = rest.p_WM[m] + d;
      in.X_WE.translation() = rest.X_WE.translation() + d;
    });
  } else {
    TimeControlSteps(state, controller, input);
  }
  state.counters["nodes"] = mesh.num_nodes();
}
void BM_ControlStepScenario(benchmark::State& state) { RunControlStepScenario(state, true); }
void BM_ControlStepScenarioBreathing(benchmark::State& state) {
  RunControlStepScenario(state, true, true);
}
void BM_ControlStepScenarioWithoutLoad(benchmark::State& state) {
  RunControlStepScenario(state, false);
}

void BM_ControlStep12(benchmark::State& state) { RunControlStep(state, SteeringDof::kCartesian6); }
void BM_ControlStep14(benchmark::State& state) { RunControlStep(state, SteeringDof::kJoint7); }
void BM_ControlStep12Flexible(benchmark::State& state) {
  RunControlStep(state, SteeringDof::kCartesian6, true);
}

BENCHMARK(BM_PlainStep)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStep12)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStepScenario)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStepScenarioBreathing)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStepScenarioWithoutLoad)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStep14)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PlainStepFlexible)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ControlStep12Flexible)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_SnapshotSolve)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SnapshotSolveContact)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
