// Patient-scene benchmarks (common/scene): one full step of the direct simulation's scene on the
// default scenario (configs/scenarios/liver_breathing.yaml): liver FEM (PCG + cached warped
// factor), skin FEM, liver-rib contacts, needle-tissue constraints, breathing. The needle is
// first inserted along the planned path until it is in the liver (the skin and the liver
// punctured), then the step is timed while the insertion continues. Measure on one core:
//   OPENBLAS_NUM_THREADS=1 taskset -c 0 scene_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// Names: what/size (#liver nodes). DirectSceneStep = needle in the liver; DirectSceneStepFree =
// before the needle reaches the skin (breathing and rib contacts only). DirectSceneFirstStep =
// the first step of a newly built scene (what a realtime run's clock meets first).
// DirectSceneSequence/<refresh>/<compliance>/size: the step-time distribution (p50_ms, p90_ms,
// p99_ms, max_ms; tests/bench/step_times.h) over 400 steps (8 s, 2 breathing cycles) with the
// needle in the liver and advancing at 1 cm/s, wall clock, one sequence per repetition; refresh
// InStep (background_refactor = false: the liver's factor refresh inside the step that asks) or
// Background (background_refactor = true: factorized on a worker, adopted refactor_adopt_delay
// steps later); compliance Rest (constraint_compliance: rest, the scenario's: A_0^-1, constant,
// a refresh costs no compliance columns) or LastFactor (constraint_compliance: last_factor: the
// liver's last factor; a swap invalidates the cached columns, recomputed in the swap step,
// swap_step_ms). After each step the sequences do the work between steps as direct_sim does
// (PatientScene::Prefetch: the compliance columns of the nodes the needle and the ribs will
// reach), timed apart: prefetch_p50_ms / prefetch_p99_ms / prefetch_max_ms; .../NoPrefetch
// leaves it to the steps. DirectSceneSequence/NeedleHeld/...: the same 400 steps with the
// needle held at the end of the plan (the tip at the target; the closed loop's final phase:
// breathing, the needle still), after inserting it there untimed; .../Threshold3 with the
// liver's refresh asked at more than 3 PCG iterations instead of the scenario's 5 (the choice
// of 2026-12-06).

#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/core/thread_priority.h"
#include "common/scene/patient_scene.h"
#include "common/scene/physics_watchdog.h"
#include "common/scene/robot_driver.h"
#include "direct_sim/scenario_loader.h"
#include "tests/bench/step_times.h"

namespace nsim {
namespace {

// What a step-time sequence changes in the default scenario (DirectSceneSequence)
struct SequenceOptions {
  bool background = true;  // patient.liver.background_refactor
  bool rest_compliance = true;  // patient.constraint_compliance: rest (else last_factor)
  bool paced = false;  // one step per time step of wall clock (realtime), else back to back
  int adopt_delay = 0;  // > 0: refactor_adopt_delay (0 keeps the scenario's)
  FactorAdoption adoption = FactorAdoption::kScheduled;
  double slice = -1.0;  // >= 0: refactor_slice (s; < 0 keeps the scenario's, 0)
  bool prefetch = true;  // false: prefetch_ahead and prefetch_rib_margin 0 (Prefetch does nothing)
  int fifo_priority = 0;  // > 0: the loop's thread in SCHED_FIFO at this priority
  int hold_steps = -1;  // >= 0: refactor_hold_steps (< 0 keeps the scenario's)
  bool needle_held = false;  // the needle held at the end of the plan, else advancing
  int refresh_threshold = 0;  // > 0: refactor_iteration_threshold (0 keeps the scenario's)

  // the scenario's keys this sequence sets
  void Apply(DirectScenario& scenario) const {
    PatientSceneConfig& scene = scenario.scene;
    scene.liver.background_refactor = background;
    scene.liver_rest_compliance = rest_compliance;
    if (adopt_delay > 0) scene.liver.refactor_adopt_delay = adopt_delay;
    scene.liver.refactor_adoption = adoption;
    if (slice >= 0.0) scene.liver.refactor_slice = slice;
    if (hold_steps >= 0) scene.liver.refactor_hold_steps = hold_steps;
    if (refresh_threshold > 0) scene.liver.refactor_iteration_threshold = refresh_threshold;
    if (!prefetch) scene.prefetch_ahead = scene.prefetch_rib_margin = 0.0;
  }
};

struct Fixture {
  DirectScenario scenario;
  InsertionPlan plan;
  std::unique_ptr<PatientScene> scene;
  double s = 0.0;  // tip travel along the plan (m)

  // the default scenario, its refreshes adopted on schedule, with the sequence's keys if given
  explicit Fixture(int nodes, const SequenceOptions* options = nullptr) {
    scenario = LoadDirectScenario(std::string(NSIM_SOURCE_DIR) +
                                  "/configs/scenarios/liver_breathing.yaml");
    if (nodes != 2660) throw std::runtime_error("only the 2660-node liver is configured");
    scenario.scene.liver.refactor_adoption = FactorAdoption::kScheduled;
    if (options) options->Apply(scenario);
    const RigidNeedleModel needle(scenario.scene.needle.geometry());
    plan = MakeInsertionPlan(scenario.scene.entry_W, scenario.scene.target_W, needle,
                             scenario.insertion.approach_distance);
    scene = std::make_unique<PatientScene>(scenario.scene, scenario.liver_mesh, scenario.skin_mesh,
                                           plan.CalcFlangePose(0.0));
  }
  // a step and the work between steps after it (PatientScene::Prefetch), as direct_sim does
  void Step() {
    s = std::min(s + 0.01 * scenario.scene.time_step, plan.total_travel());
    scene->Step(plan.CalcFlangePose(s));
    scene->Prefetch();
  }
};

void BM_DirectSceneStep(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  // insert until the liver is punctured and the tip is 1 cm deep in it
  while (!f.scene->GetTissueStatus(kLiverTissue).punctured ||
         f.scene->GetTissueStatus(kLiverTissue).depth < 0.01)
    f.Step();
  SceneStepReport report;
  std::vector<double> ms;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    report = f.scene->Step(f.plan.CalcFlangePose(f.s += 0.01 * f.scenario.scene.time_step));
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  // the median step (wall): occasional steps refresh the cached FEM factor
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["p90_ms"] = ms[ms.size() * 9 / 10];
  state.counters["rows"] = report.num_rows;
  state.counters["rib_rows"] = report.num_rib_contacts;
  state.counters["liver_depth_mm"] = 1e3 * f.scene->GetTissueStatus(kLiverTissue).depth;
}
BENCHMARK(BM_DirectSceneStep)->Arg(2660)->Unit(benchmark::kMillisecond)->Iterations(100);

void BM_DirectSceneStepFree(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  for (int i = 0; i < 20; ++i) f.scene->Step(f.plan.CalcFlangePose(0.0));
  SceneStepReport report;
  double cg = 0;
  std::vector<double> ms;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    report = f.scene->Step(f.plan.CalcFlangePose(0.0));
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
    cg += report.liver_stats.cg_iterations;
  }
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["rib_rows"] = report.num_rib_contacts;
  state.counters["cg_iterations"] = cg / state.iterations();
}
BENCHMARK(BM_DirectSceneStepFree)->Arg(2660)->Unit(benchmark::kMillisecond)->Iterations(100);

// the first step of a new scene (the first step a realtime run times): each iteration builds
// the scene (not timed) and times its first step; the time is manual (the step alone)
void BM_DirectSceneFirstStep(benchmark::State& state) {
  std::vector<double> ms;
  SceneStepReport report;
  for (auto _ : state) {
    Fixture f(static_cast<int>(state.range(0)));
    const auto start = std::chrono::steady_clock::now();
    report = f.scene->Step(f.plan.CalcFlangePose(0.0));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(seconds);
    ms.push_back(1e3 * seconds);
  }
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["max_ms"] = ms.back();
  state.counters["rib_rows"] = report.num_rib_contacts;
}
BENCHMARK(BM_DirectSceneFirstStep)
    ->Arg(2660)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5)
    ->UseManualTime();

// the step-time distribution over 400 steps with the needle in the liver (Iterations = steps)
// paced: one step per time step of wall clock (sleeping until the next period, as realtime mode
// does), so that the background refresh can use the time the steps leave
void DirectSceneSequence(benchmark::State& state, const SequenceOptions& o) {
  Fixture f(2660, &o);
  // held: to the end of the plan (the loop below then keeps the needle there); else 1 cm into
  // the liver (the loop advances it)
  while (o.needle_held ? f.s < f.plan.total_travel()
                     : !f.scene->GetTissueStatus(kLiverTissue).punctured ||
                           f.scene->GetTissueStatus(kLiverTissue).depth < 0.01)
    f.Step();
  // the loop's thread in SCHED_FIFO (direct_sim's run.rt_priority) for the timed steps; the
  // refresh worker, started with the scene, stays in SCHED_IDLE
  const FifoScope fifo(o.fifo_priority);
  if (!fifo.error().empty()) {
    state.SkipWithError(fifo.error().c_str());
    return;
  }
  StepTimes times(static_cast<size_t>(state.max_iterations));
  StepTimes between(static_cast<size_t>(state.max_iterations));
  double prefetch_columns = 0;
  std::vector<double> swap_ms, request_ms;
  double swaps = 0, waits = 0, refactorizations = 0, cg = 0, steps = 0, rows = 0, lags = 0;
  double slice_wait = 0, sliced_steps = 0, preempted = 0, held = 0;
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(f.scenario.scene.time_step));
  auto next = std::chrono::steady_clock::now();
  for (auto _ : state) {
    if (o.paced) {
      next += period;
      std::this_thread::sleep_until(next);
    }
    rusage before{}, after{};
    getrusage(RUSAGE_THREAD, &before);
    const SceneStepReport report = times.Time([&] {
      f.s = std::min(f.s + 0.01 * f.scenario.scene.time_step, f.plan.total_travel());
      return f.scene->Step(f.plan.CalcFlangePose(f.s));
    });
    getrusage(RUSAGE_THREAD, &after);
    preempted += after.ru_nivcsw > before.ru_nivcsw;
    held += report.refresh_held;
    // the work between steps, timed apart (realtime: in the period's time left after the step)
    prefetch_columns += between.Time([&] { return f.scene->Prefetch(); });
    const FemStepStats& liver = report.liver_stats;
    swaps += liver.factor_swapped;
    waits += liver.waited_for_worker;
    lags += liver.adoption_lag;
    slice_wait += liver.slice_wait;
    sliced_steps += liver.slice_wait > 0.0;
    refactorizations += liver.refactorized;
    cg += liver.cg_iterations;
    rows += report.num_rows;
    if (liver.factor_swapped) swap_ms.push_back(times.last());
    if (liver.refresh_requested || liver.refactorized) request_ms.push_back(times.last());
    steps += 1;
  }
  times.Report(state);
  state.counters["prefetch_p50_ms"] = between.Percentile(0.50);
  state.counters["prefetch_p99_ms"] = between.Percentile(0.99);
  state.counters["prefetch_max_ms"] = between.Percentile(1.00);
  state.counters["prefetch_columns_per_step"] = prefetch_columns / steps;
  state.counters["liver_refactor_per_step"] = refactorizations / steps;
  state.counters["bg_swaps_per_step"] = swaps / steps;
  state.counters["waits_per_swap"] = swaps > 0 ? waits / swaps : 0.0;
  state.counters["adoption_lag"] = swaps > 0 ? lags / swaps : 0.0;  // steps, request to adoption
  state.counters["swap_step_ms"] = StepTimes::Percentile(swap_ms, 0.5);
  state.counters["request_step_ms"] = StepTimes::Percentile(request_ms, 0.5);
  state.counters["cg_iterations"] = cg / steps;
  // on one CPU (FemConfig::refactor_slice): the steps that gave the refresh the core, and the
  // mean time they gave it
  state.counters["sliced_steps"] = sliced_steps / steps;
  state.counters["slice_ms"] = sliced_steps > 0 ? 1e3 * slice_wait / sliced_steps : 0.0;
  state.counters["rows"] = rows / steps;
  // steps the scheduler took the core from at least once (another thread ran meanwhile)
  state.counters["preempted_steps"] = preempted / steps;
  // steps that kept the refresh off the CPU (one CPU, patient.liver.refactor_hold_steps)
  state.counters["held_steps"] = held / steps;
  state.counters["liver_depth_mm"] = 1e3 * f.scene->GetTissueStatus(kLiverTissue).depth;
}

// registers DirectSceneSequence/<name> with these options (400 steps, wall clock)
void RegisterSequence(const std::string& name, const SequenceOptions& options) {
  benchmark::RegisterBenchmark(("DirectSceneSequence/" + name).c_str(),
                               [options](benchmark::State& s) { DirectSceneSequence(s, options); })
      ->Unit(benchmark::kMillisecond)
      ->Iterations(400)
      ->UseRealTime();
}

void RegisterSequences() {
  for (bool rest : {true, false})
    for (bool background : {false, true}) {
      SequenceOptions o;
      o.background = background;
      o.rest_compliance = rest;
      RegisterSequence(std::string(background ? "Background" : "InStep") + "/" +
                           (rest ? "Rest" : "LastFactor") + "/2660",
                       o);
    }
  // the default scenario's setting in realtime: one step per 20 ms, the refresh in the time
  // between steps (its worker at the lowest priority); on one core this is what a realtime
  // direct_sim does with no other process beside it
  SequenceOptions paced;
  paced.paced = true;
  RegisterSequence("Paced/Rest/2660", paced);
  // the same with the factor adopted later: on a machine where a factorization takes longer
  // than refactor_adopt_delay steps, the adopting step waits for the worker (waits_per_swap)
  for (int delay : {6, 10}) {
    SequenceOptions o = paced;
    o.adopt_delay = delay;
    RegisterSequence("Paced/Rest/2660/AdoptDelay" + std::to_string(delay), o);
  }
  // refactor_adoption: when_ready (realtime): each refresh adopted at the first step that finds
  // it done, no step waiting for the worker
  SequenceOptions paced_ready = paced;
  paced_ready.adoption = FactorAdoption::kWhenReady;
  RegisterSequence("Paced/Rest/2660/WhenReady", paced_ready);
  // the same without the refresh's hold (refactor_hold_steps 0): on one CPU the refresh then
  // takes the core from a step for a scheduler tick now and then (the scenario's default holds
  // it for the step; on two CPUs the two are the same)
  SequenceOptions no_hold = paced_ready;
  no_hold.hold_steps = 0;
  RegisterSequence("Paced/Rest/2660/WhenReady/NoHold", no_hold);
  // the same with the loop's thread in SCHED_FIFO (priority 10; direct_sim's run.rt_priority):
  // on one core no step is preempted by the refresh (skipped where the class is not permitted)
  SequenceOptions fifo = paced_ready;
  fifo.fifo_priority = 10;
  RegisterSequence("Paced/Rest/2660/WhenReady/Fifo", fifo);
  // the needle held at the target while the liver breathes (the closed loop's final phase), back
  // to back with scheduled adoption (a lockstep run) and paced with adoption when ready (a
  // realtime direct_sim), each with the scenario's refresh threshold and with 3
  for (int threshold : {0, 3})
    for (bool is_paced : {false, true}) {
      SequenceOptions o = is_paced ? paced_ready : SequenceOptions{};
      o.needle_held = true;
      o.refresh_threshold = threshold;
      RegisterSequence(std::string("NeedleHeld/") +
                           (is_paced ? "Paced/Rest/2660/WhenReady" : "Background/Rest/2660") +
                           (threshold > 0 ? "/Threshold" + std::to_string(threshold) : ""),
                       o);
    }
  // back to back with when_ready adoption
  SequenceOptions ready;
  ready.adoption = FactorAdoption::kWhenReady;
  // without the work between steps (prefetch_ahead and prefetch_rib_margin 0): the steps then
  // solve the compliance columns of the nodes the needle and the ribs reach
  SequenceOptions no_prefetch = ready;
  no_prefetch.prefetch = false;
  RegisterSequence("Background/Rest/2660/WhenReady/NoPrefetch", no_prefetch);
  // with refactor_slice 4 ms and without: on one CPU (taskset -c N) the first spreads each
  // refresh over the steps, the second leaves the worker only what the steps leave, little when
  // they run back to back; on two CPUs the two are the same (the slice is not used)
  for (bool sliced : {true, false}) {
    SequenceOptions o = ready;
    o.slice = sliced ? 0.004 : 0.0;
    RegisterSequence(std::string("Background/Rest/2660/WhenReady") + (sliced ? "" : "/NoSlice"), o);
  }
}

// the physics watchdog's check of one state (patient loop, every step): bounds, kinetic
// energies, and the inverted-element count of the liver and the skin
void BM_WatchdogCheck(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  std::vector<Eigen::Vector3d> markers;
  f.scene->CalcMarkerPositions(&markers);
  const Eigen::Vector3d target = f.scene->CalcTargetPosition(), tip = f.scene->CalcTipPosition();
  const PhysicsWatchdog dog(WatchdogConfig{}, target, markers);
  for (int i = 0; i < 20; ++i) f.Step();
  WatchdogInput in;
  in.target = &target;
  in.markers = &markers;
  in.tip = &tip;
  in.liver = &f.scene->model().liver();
  in.liver_state = &f.scene->state().liver;
  in.skin = &f.scene->model().skin();
  in.skin_state = &f.scene->state().skin;
  for (auto _ : state) benchmark::DoNotOptimize(dog.Check(in));
  state.counters["tets"] = f.scene->model().liver().num_tets() + f.scene->model().skin().num_tets();
}
BENCHMARK(BM_WatchdogCheck)->Arg(2660)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace nsim

int main(int argc, char** argv) {
  nsim::RegisterSequences();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
