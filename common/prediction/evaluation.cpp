#include "common/prediction/evaluation.h"

#include <cmath>
#include <limits>
#include <random>

#include "common/core/error.h"
#include "common/prediction/metrics.h"

namespace nsim {

Eigen::MatrixXd MarkerTrajectory(const MarkerStream& stream, int m) {
  NSIM_CHECK(m >= 0 && m < stream.num_markers, "marker ", m, " out of range");
  Eigen::MatrixXd y(static_cast<long>(stream.frames.size()), 3);
  for (size_t k = 0; k < stream.frames.size(); ++k)
    y.row(static_cast<long>(k)) = stream.frames[k].p_WM[m].transpose();
  return y;
}

std::vector<double> FrameTimes(const MarkerStream& stream) {
  std::vector<double> t(stream.frames.size());
  for (size_t k = 0; k < t.size(); ++k) t[k] = stream.frames[k].stamp.sim_time;
  return t;
}

MarkerStream AddWhiteNoise(const MarkerStream& clean, double snr_db, uint64_t seed) {
  if (std::isnan(snr_db) || snr_db == -std::numeric_limits<double>::infinity())
    throw InputError(Str("SNR must be a number of dB or inf, got ", snr_db));
  MarkerStream noisy = clean;
  if (std::isinf(snr_db) || clean.frames.empty()) return noisy;
  std::seed_seq seq{seed, uint64_t{0x6e6f6973}};
  std::mt19937_64 rng(seq);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> sigma(clean.num_markers);
  for (int m = 0; m < clean.num_markers; ++m)
    sigma[m] =
        std::sqrt(SignalPower(MarkerTrajectory(clean, m)) / (3.0 * std::pow(10.0, snr_db / 10)));
  for (auto& frame : noisy.frames) {
    for (int m = 0; m < clean.num_markers; ++m) {
      for (int c = 0; c < 3; ++c) frame.p_WM[m][c] += sigma[m] * normal(rng);
    }
  }
  return noisy;
}

double MeasureSnrDb(const MarkerStream& clean, const MarkerStream& noisy, int m) {
  const Eigen::MatrixXd y = MarkerTrajectory(clean, m);
  const Eigen::MatrixXd noise = MarkerTrajectory(noisy, m) - y;
  return 10.0 * std::log10(SignalPower(y) / noise.rowwise().squaredNorm().mean());
}

PredictionEvaluation EvaluatePrediction(const MarkerStream& measured, const MarkerStream& reference,
                                        const PredictionConfig& config, double horizon) {
  if (!(horizon >= 0) || !std::isfinite(horizon))
    throw InputError(Str("prediction horizon must be >= 0 and finite (s), got ", horizon));
  if (measured.num_markers != reference.num_markers ||
      measured.frames.size() != reference.frames.size())
    throw InputError(Str("evaluation: measured stream (", measured.num_markers, " markers, ",
                         measured.frames.size(), " frames) and reference (", reference.num_markers,
                         " markers, ", reference.frames.size(), " frames) differ"));
  const long num_frames = static_cast<long>(measured.frames.size());
  if (num_frames < 3) throw InputError(Str("evaluation: needs >= 3 frames, got ", num_frames));
  for (long k = 0; k < num_frames; ++k) {
    const double a = measured.frames[k].stamp.sim_time, b = reference.frames[k].stamp.sim_time;
    if (!(std::abs(a - b) <= 1e-9 * (1 + std::abs(b))))
      throw InputError(Str("evaluation: frame ", k, " time differs between measured (", a,
                           " s) and reference (", b, " s)"));
  }
  const int num_markers = measured.num_markers;
  MarkerPredictor predictor(config, num_markers);

  // causal run: predictions and the delayed measurement, both placed at t_k + h
  std::vector<double> t_target;
  std::vector<Eigen::MatrixXd> predicted(num_markers), delayed(num_markers);
  for (auto& p : predicted) p.resize(num_frames, 3);
  for (auto& d : delayed) d.resize(num_frames, 3);
  std::vector<Eigen::Vector3d> p_WM(num_markers);
  PredictionEvaluation result;
  result.horizon = horizon;
  result.first_ready_frame = -1;
  for (long k = 0; k < num_frames; ++k) {
    const MarkerFrame& frame = measured.frames[k];
    predictor.Update(frame);
    if (!predictor.ready()) continue;
    if (result.first_ready_frame < 0) result.first_ready_frame = static_cast<int>(k);
    predictor.Predict(horizon, &p_WM);
    const long j = static_cast<long>(t_target.size());
    t_target.push_back(frame.stamp.sim_time + horizon);
    for (int m = 0; m < num_markers; ++m) {
      predicted[m].row(j) = p_WM[m].transpose();
      delayed[m].row(j) = frame.p_WM[m].transpose();
    }
  }
  const std::vector<double> t_frames = FrameTimes(measured);
  const double t_last = t_frames.back();
  const double step = (t_last - t_frames.front()) / (num_frames - 1);
  constexpr int kMinGrid = 3;  // the jitter needs 3 grid points
  if (t_target.size() < 2 || t_target.front() + (kMinGrid - 1) * step > t_last + 1e-9 * step)
    throw InputError(Str("evaluation: the stream (", num_frames, " frames, ",
                         t_last - t_frames.front(), " s) is too short for filter ",
                         ToString(config.filter), " (ready after frame ", result.first_ready_frame,
                         ", pca_window ", config.pca_window, ") and horizon ", horizon, " s"));
  const long used = static_cast<long>(t_target.size());
  result.t_grid = UniformGrid(t_target.front(), t_last, step);
  result.markers.resize(num_markers);
  for (int m = 0; m < num_markers; ++m) {
    MarkerEvaluation& e = result.markers[m];
    e.reference = ResampleLinear(t_frames, MarkerTrajectory(reference, m), result.t_grid);
    e.predicted = ResampleLinear(t_target, predicted[m].topRows(used), result.t_grid);
    e.delayed = ResampleLinear(t_target, delayed[m].topRows(used), result.t_grid);
    e.rms = RmsError(e.predicted, e.reference);
    e.rms_delayed = RmsError(e.delayed, e.reference);
    e.nrms = NormalizedRmsError(e.predicted, e.delayed, e.reference);
    e.jitter = Jitter(e.predicted);
    e.window = predictor.filter(m).window();
  }
  return result;
}

}  // namespace nsim
