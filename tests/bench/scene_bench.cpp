// Patient-scene benchmarks (common/scene): one full step of the direct simulation's scene on the
// default scenario (configs/scenarios/liver_breathing.yaml): liver FEM (PCG + cached warped
// factor), skin FEM, liver-rib contacts, needle-tissue constraints, breathing. The needle is
// first inserted along the planned path until it is in the liver (the skin and the liver
// punctured), then the step is timed while the insertion continues. Measure on one core:
//   OPENBLAS_NUM_THREADS=1 taskset -c 0 scene_bench --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// Names: what/size (#liver nodes). DirectSceneStep = needle in the liver; DirectSceneStepFree =
// before the needle reaches the skin (breathing and rib contacts only).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "common/scene/patient_scene.h"
#include "common/scene/robot_driver.h"
#include "direct_sim/scenario_loader.h"

namespace nsim {
namespace {

struct Fixture {
  DirectScenario scenario;
  InsertionPlan plan;
  std::unique_ptr<PatientScene> scene;
  double s = 0.0;  // tip travel along the plan (m)

  explicit Fixture(int nodes) {
    scenario = LoadDirectScenario(std::string(NSIM_SOURCE_DIR) +
                                  "/configs/scenarios/liver_breathing.yaml");
    if (nodes != 2660) throw std::runtime_error("only the 2660-node liver is configured");
    const RigidNeedleModel needle(scenario.scene.needle.geometry());
    plan = MakeInsertionPlan(scenario.scene.entry_W, scenario.scene.target_W, needle,
                             scenario.insertion.approach_distance);
    scene = std::make_unique<PatientScene>(scenario.scene, scenario.liver_mesh, scenario.skin_mesh,
                                           plan.CalcFlangePose(0.0));
  }
  void Step() {
    s = std::min(s + 0.01 * scenario.scene.time_step, plan.total_travel());
    scene->Step(plan.CalcFlangePose(s));
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

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
