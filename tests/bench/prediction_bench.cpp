// Prediction timings: one MarkerPredictor update + prediction of 5 markers (target <= 20 us) and
// one golden-section window search over a 300-sample PCA buffer (target <= 5 ms); the online
// score of one frame's predictions, without and with the shrinkage factor (prediction.shrink).
#include <benchmark/benchmark.h>

#include <vector>

#include "common/breathing/breathing.h"
#include "common/breathing/marker_motion.h"
#include "common/prediction/marker_predictor.h"
#include "common/prediction/pca_buffer.h"
#include "common/prediction/polynomial_filter.h"
#include "common/prediction/prediction_score.h"

namespace nsim {
namespace {

constexpr int kMarkers = 5;
constexpr int kPcaWindow = 300;

MarkerStream Stream(double duration) {
  BreathingConfig b;
  b.horizon = duration + 10;
  MarkerMotionConfig m;
  m.duration = duration;
  m.num_markers = kMarkers;
  return MakeBreathingMarkerStream(BreathingModel(b), m);
}

// steady state: the buffer is full, the PCA is recomputed every sample (pca_update_interval 1)
void PredictorUpdate(benchmark::State& state, PredictionFilterKind kind, int window) {
  const MarkerStream stream = Stream(120);
  const int n = static_cast<int>(stream.frames.size());
  PredictionConfig config;
  config.filter = kind;
  config.pca_window = kPcaWindow;
  config.optimize_window = false;
  config.window = window;
  MarkerPredictor predictor(config, kMarkers);
  for (int k = 0; k < kPcaWindow; ++k) predictor.Update(stream.frames[k]);
  MarkerFrame frame = stream.frames[0];
  std::vector<Eigen::Vector3d> predicted(kMarkers);
  const double period = stream.frames.back().stamp.sim_time + 1 / 30.0;
  long k = kPcaWindow;
  for (auto _ : state) {
    // replay the stream forever, time kept increasing
    const MarkerFrame& source = stream.frames[k % n];
    frame.stamp.sim_time = source.stamp.sim_time + period * (k / n);
    for (int m = 0; m < kMarkers; ++m) frame.p_WM[m] = source.p_WM[m];
    predictor.Update(frame);
    predictor.Predict(0.16, &predicted);
    benchmark::DoNotOptimize(predicted.data());
    ++k;
  }
}

// Algorithm 1 + golden search over [order+1, 59] on a 300-sample projected buffer
void WindowSearch(benchmark::State& state, int order) {
  const MarkerStream stream = Stream(20);
  PcaBuffer buffer(kPcaWindow);
  for (int k = 0; k < kPcaWindow; ++k)
    buffer.Push(stream.frames[k].stamp.sim_time, stream.frames[k].p_WM[0]);
  PrincipalAxes axes;
  buffer.CalcPrincipalAxes(&axes);
  std::vector<double> t(kPcaWindow), y(kPcaWindow);
  for (int i = 0; i < kPcaWindow; ++i) {
    t[i] = buffer.time(i);
    y[i] = axes.Project(buffer.position(i));
  }
  int window = 0;
  for (auto _ : state) {
    window = SearchWindow(t.data(), y.data(), kPcaWindow, order, order + 1, 59, 1).x;
    benchmark::DoNotOptimize(window);
  }
  state.counters["window"] = window;
}

// what the controller loop does per frame for its score: a measurement, a prediction 6 frames
// ahead; with `recent` > 0 also the shrinkage factors over the newest `recent` scored
// predictions (recent = 0: the score alone, the loop's work before prediction.shrink)
void ScoreFrame(benchmark::State& state, int recent) {
  const MarkerStream stream = Stream(120);
  const int n = static_cast<int>(stream.frames.size());
  const double period = stream.frames.back().stamp.sim_time + 1 / 30.0;
  PredictionScore score(recent);
  std::vector<Eigen::Vector3d> predicted(kMarkers);
  long k = 0;
  for (auto _ : state) {
    const MarkerFrame& source = stream.frames[k % n];
    const double t = source.stamp.sim_time + period * (k / n);
    score.AddMeasurement(t, source.p_WM);
    for (int m = 0; m < kMarkers; ++m) predicted[m] = source.p_WM[m] + Eigen::Vector3d(1e-4, 0, 0);
    score.AddPrediction(t + 0.2, predicted, source.p_WM);
    if (recent > 0) benchmark::DoNotOptimize(score.Shrinkage().data());
    ++k;
  }
}

BENCHMARK_CAPTURE(ScoreFrame, score, 0)->Name("ScoreFrame/5markers/score");
BENCHMARK_CAPTURE(ScoreFrame, shrink300, 300)->Name("ScoreFrame/5markers/score+shrinkage300");
BENCHMARK_CAPTURE(PredictorUpdate, lf_wf50, PredictionFilterKind::kLinear, 50)
    ->Name("PredictorUpdate/5markers/WF50");
BENCHMARK_CAPTURE(PredictorUpdate, lf_wf10, PredictionFilterKind::kLinear, 10)
    ->Name("PredictorUpdate/5markers/WF10");
BENCHMARK_CAPTURE(PredictorUpdate, kalman, PredictionFilterKind::kHarmonicKalman, 10)
    ->Name("PredictorUpdate/5markers/kalman");
BENCHMARK_CAPTURE(PredictorUpdate, none, PredictionFilterKind::kNone, 10)
    ->Name("PredictorUpdate/5markers/none");
BENCHMARK_CAPTURE(WindowSearch, order2, 2)
    ->Name("WindowSearch/WP300/order2")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(WindowSearch, order1, 1)
    ->Name("WindowSearch/WP300/order1")
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
