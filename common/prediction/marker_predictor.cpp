#include "common/prediction/marker_predictor.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/prediction/harmonic_kalman.h"
#include "common/prediction/polynomial_filter.h"

namespace nsim {

PredictionFilterKind ParsePredictionFilter(const std::string& name) {
  if (name == "none") return PredictionFilterKind::kNone;
  if (name == "lf") return PredictionFilterKind::kLinear;
  if (name == "kalman") return PredictionFilterKind::kHarmonicKalman;
  throw InputError(Str("prediction.filter must be one of none, lf, kalman; got '", name, "'"));
}

std::string ToString(PredictionFilterKind kind) {
  switch (kind) {
    case PredictionFilterKind::kNone:
      return "none";
    case PredictionFilterKind::kLinear:
      return "lf";
    case PredictionFilterKind::kHarmonicKalman:
      return "kalman";
  }
  return "unknown";
}

void PredictionConfig::Validate() const {
  if (pca_window < 3)
    throw InputError(Str("prediction.pca_window must be >= 3 samples, got ", pca_window));
  // buffers are allocated at these sizes: 1e5 samples is over half an hour at 50 Hz, far
  // beyond the few breathing cycles a predictor looks at
  constexpr double kMaxSamples = 100000;
  CheckAtMost(pca_window, kMaxSamples, "prediction.pca_window", "samples");
  CheckAtMost(window, kMaxSamples, "prediction.window", "samples");
  CheckAtMost(window_max, kMaxSamples, "prediction.window_max", "samples");
  CheckAtMost(search_lead, kMaxSamples, "prediction.search_lead", "samples");
  CheckAtMost(pca_update_interval, 10 * kMaxSamples, "prediction.pca_update_interval", "samples");
  CheckAtMost(search_interval, 10 * kMaxSamples, "prediction.search_interval", "samples");
  if (pca_update_interval < 0)
    throw InputError(Str("prediction.pca_update_interval must be >= 0, got ", pca_update_interval));
  if (order < 1 || order > kMaxPolynomialOrder)
    throw InputError(
        Str("prediction.order must be in [1, ", kMaxPolynomialOrder, "], got ", order));
  if (window < order + 1)
    throw InputError(Str("prediction.window must be >= order+1 (", order + 1, "), got ", window));
  if (window > pca_window)
    throw InputError(
        Str("prediction.window must be <= pca_window (", pca_window, "), got ", window));
  if (search_interval < 0)
    throw InputError(Str("prediction.search_interval must be >= 0, got ", search_interval));
  if (search_lead < 1)
    throw InputError(Str("prediction.search_lead must be >= 1 sample, got ", search_lead));
  if (optimize_window) {
    if (window_max < order + 2)
      throw InputError(Str("prediction.window_max must be >= order+2 (", order + 2,
                           ") to search [order+1, window_max-1], got ", window_max));
    if (pca_window < window_max + search_lead)
      throw InputError(Str("prediction.pca_window must be >= window_max + search_lead (",
                           window_max + search_lead, ") for the window search, got ", pca_window));
  }
  if (kalman_harmonics < 1 || kalman_harmonics > kMaxHarmonics)
    throw InputError(Str("prediction.kalman_harmonics must be in [1, ", kMaxHarmonics, "], got ",
                         kalman_harmonics));
  if (!(kalman_min_period > 0))
    throw InputError(Str("prediction.kalman_min_period must be > 0 (s), got ", kalman_min_period));
  if (!(kalman_max_period > kalman_min_period) || !std::isfinite(kalman_max_period))
    throw InputError(Str("prediction.kalman_max_period must be > kalman_min_period (",
                         kalman_min_period, " s), got ", kalman_max_period));
  if (!(kalman_nominal_period > 0) || !std::isfinite(kalman_nominal_period))
    throw InputError(
        Str("prediction.kalman_nominal_period must be > 0 (s), got ", kalman_nominal_period));
  if (!(kalman_harmonic_walk >= 0) || !std::isfinite(kalman_harmonic_walk))
    throw InputError(
        Str("prediction.kalman_harmonic_walk must be >= 0, got ", kalman_harmonic_walk));
  if (!(kalman_baseline_walk >= 0) || !std::isfinite(kalman_baseline_walk))
    throw InputError(
        Str("prediction.kalman_baseline_walk must be >= 0, got ", kalman_baseline_walk));
  if (!(kalman_measurement_std >= 0) || !std::isfinite(kalman_measurement_std))
    throw InputError(
        Str("prediction.kalman_measurement_std must be >= 0 (m), got ", kalman_measurement_std));
  if (filter == PredictionFilterKind::kHarmonicKalman && pca_window < 16)
    throw InputError(
        Str("prediction.pca_window must be >= 16 samples for the kalman filter's "
            "period estimate, got ",
            pca_window));
}

namespace {

// no prediction: the last sample
class LastSampleFilter final : public MarkerFilter {
 public:
  void Update(double, const Eigen::Vector3d& p) override {
    last_ = p;
    ready_ = true;
  }
  Eigen::Vector3d Predict(double) override { return last_; }
  bool ready() const override { return ready_; }

 private:
  Eigen::Vector3d last_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  bool ready_ = false;
};

// the PCA rolling buffer and its recomputation schedule, shared by LF and Kalman
class PcaFilter : public MarkerFilter {
 public:
  void SetSearchLead(int samples) override { config_.search_lead = samples; }
  explicit PcaFilter(const PredictionConfig& config)
      : config_(config), buffer_(config.pca_window), t_(config.pca_window), y_(config.pca_window) {}

  bool ready() const override { return ready_; }
  const PrincipalAxes* axes() const override { return ready_ ? &axes_ : nullptr; }

 protected:
  // pushes the sample; recomputes the axes when the buffer first fills and then on schedule.
  // Returns false while the buffer is filling.
  bool PushSample(double t, const Eigen::Vector3d& p) {
    buffer_.Push(t, p);
    if (!buffer_.full()) return false;
    if (!ready_ ||
        (config_.pca_update_interval > 0 && ++since_pca_ >= config_.pca_update_interval)) {
      buffer_.CalcPrincipalAxes(&axes_);
      since_pca_ = 0;
    }
    return true;
  }
  // whether a search (LF window, Kalman period) is due after this sample
  bool SearchDue() {
    if (!ready_) return true;
    if (config_.search_interval > 0 && ++since_search_ >= config_.search_interval) {
      since_search_ = 0;
      return true;
    }
    return false;
  }
  // times and first PCs of the newest `count` samples into t_, y_ (chronological)
  void ProjectNewest(int count) {
    const int first = buffer_.size() - count;
    for (int i = 0; i < count; ++i) {
      t_[i] = buffer_.time(first + i);
      y_[i] = axes_.Project(buffer_.position(first + i));
    }
  }

  PredictionConfig config_;
  PcaBuffer buffer_;
  PrincipalAxes axes_;
  std::vector<double> t_, y_;  // scratch, WP each
  bool ready_ = false;
  int since_pca_ = 0, since_search_ = 0;
};

// PCA + polynomial linear filter (thesis §4.1.1-4.1.4)
class LinearFilter final : public PcaFilter {
 public:
  explicit LinearFilter(const PredictionConfig& config)
      : PcaFilter(config), window_(config.window) {}

  void Update(double t, const Eigen::Vector3d& p) override {
    if (!PushSample(t, p)) return;
    if (config_.optimize_window && SearchDue()) {
      ProjectNewest(buffer_.size());
      window_ = SearchWindow(t_.data(), y_.data(), buffer_.size(), config_.order, config_.order + 1,
                             config_.window_max - 1, config_.search_lead)
                    .x;
    }
    ready_ = true;
  }

  Eigen::Vector3d Predict(double horizon) override {
    if (!ready_) return buffer_.newest_position();
    ProjectNewest(window_);
    const double pc = ExtrapolatePolynomial(t_.data(), y_.data(), window_, config_.order,
                                            buffer_.newest_time() + horizon);
    return axes_.Reproject(pc);
  }

  int window() const override { return window_; }

 private:
  int window_;
};

// PCA + Kalman filter on a harmonic breathing model (harmonic_kalman.h)
class KalmanFilter final : public PcaFilter {
 public:
  explicit KalmanFilter(const PredictionConfig& config) : PcaFilter(config) {}

  void Update(double t, const Eigen::Vector3d& p) override {
    if (!PushSample(t, p)) return;
    if (!ready_) {
      // first fill: tune, then run the filter through the whole buffer
      SearchDue();
      const int n = buffer_.size();
      ProjectNewest(n);
      const HarmonicKalmanParams params = Tune(n);
      kalman_.Reset(params, y_[0], signal_variance_ + params.measurement_variance);
      for (int i = 1; i < n; ++i) kalman_.Update(t_[i] - t_[i - 1], y_[i]);
      last_t_ = t;
      ready_ = true;
      return;
    }
    kalman_.Update(t - last_t_, axes_.Project(p));
    last_t_ = t;
    if (SearchDue()) {
      ProjectNewest(buffer_.size());
      kalman_.SetParams(Tune(buffer_.size()));
    }
  }

  Eigen::Vector3d Predict(double horizon) override {
    if (!ready_) return buffer_.newest_position();
    return axes_.Reproject(kalman_.Predict(horizon));
  }

 private:
  // frequency, noise and process noise from the projected buffer in t_, y_
  HarmonicKalmanParams Tune(int n) {
    double mean = 0.0, var = 0.0;
    for (int i = 0; i < n; ++i) mean += y_[i];
    mean /= n;
    for (int i = 0; i < n; ++i) var += (y_[i] - mean) * (y_[i] - mean);
    signal_variance_ = std::max(var / n, kMinVariance);
    double period = EstimatePeriod(t_.data(), y_.data(), n, config_.kalman_min_period,
                                   config_.kalman_max_period);
    if (!std::isfinite(period)) period = config_.kalman_nominal_period;
    HarmonicKalmanParams params;
    params.harmonics = config_.kalman_harmonics;
    params.omega = 2 * kPi / period;
    const double r = config_.kalman_measurement_std > 0
                         ? config_.kalman_measurement_std * config_.kalman_measurement_std
                         : EstimateNoiseVariance(y_.data(), n);
    params.measurement_variance = std::max(r, kMinVariance);
    params.harmonic_diffusion =
        config_.kalman_harmonic_walk * config_.kalman_harmonic_walk * signal_variance_;
    params.baseline_diffusion =
        config_.kalman_baseline_walk * config_.kalman_baseline_walk * signal_variance_;
    return params;
  }

  static constexpr double kPi = 3.14159265358979323846;
  static constexpr double kMinVariance = 1e-18;  // (1 nm)^2: floor for degenerate buffers
  HarmonicKalman kalman_;
  double last_t_ = 0.0;
  double signal_variance_ = kMinVariance;
};

}  // namespace

std::unique_ptr<MarkerFilter> MakeMarkerFilter(const PredictionConfig& config) {
  config.Validate();
  switch (config.filter) {
    case PredictionFilterKind::kNone:
      return std::make_unique<LastSampleFilter>();
    case PredictionFilterKind::kLinear:
      return std::make_unique<LinearFilter>(config);
    case PredictionFilterKind::kHarmonicKalman:
      return std::make_unique<KalmanFilter>(config);
  }
  NSIM_CHECK(false, "unknown prediction filter kind");
  return nullptr;
}

MarkerPredictor::MarkerPredictor(const PredictionConfig& config, int num_markers)
    : config_(config), last_time_(std::numeric_limits<double>::quiet_NaN()) {
  config_.Validate();
  if (num_markers < 1)
    throw InputError(Str("marker predictor needs >= 1 marker, got ", num_markers));
  for (int m = 0; m < num_markers; ++m) filters_.push_back(MakeMarkerFilter(config_));
}

void MarkerPredictor::Update(const MarkerFrame& frame) {
  const double t = frame.stamp.sim_time;
  if (static_cast<int>(frame.p_WM.size()) != num_markers())
    throw InputError(Str("marker frame seq ", frame.stamp.seq, ": expected ", num_markers(),
                         " markers, got ", frame.p_WM.size()));
  if (!std::isfinite(t))
    throw InputError(Str("marker frame seq ", frame.stamp.seq, ": time is not finite (", t, ")"));
  if (!std::isnan(last_time_) && !(t > last_time_))
    throw InputError(Str("marker frame seq ", frame.stamp.seq, ": time ", t,
                         " s does not increase (previous ", last_time_, " s)"));
  for (int m = 0; m < num_markers(); ++m) {
    if (!frame.p_WM[m].allFinite())
      throw InputError(Str("marker frame seq ", frame.stamp.seq, ": marker ", m,
                           " position is not finite (", frame.p_WM[m].transpose(), ")"));
  }
  for (int m = 0; m < num_markers(); ++m) filters_[m]->Update(t, frame.p_WM[m]);
  last_time_ = t;
}

void MarkerPredictor::Predict(double horizon, std::vector<Eigen::Vector3d>* p_WM) {
  if (!(horizon >= 0) || !std::isfinite(horizon))
    throw InputError(Str("prediction horizon must be >= 0 and finite (s), got ", horizon));
  NSIM_CHECK(!std::isnan(last_time_), "MarkerPredictor::Predict before the first Update");
  if (static_cast<int>(p_WM->size()) != num_markers()) p_WM->resize(num_markers());
  for (int m = 0; m < num_markers(); ++m) (*p_WM)[m] = filters_[m]->Predict(horizon);
}

void MarkerPredictor::SetSearchLead(int samples) {
  const int most = config_.optimize_window ? config_.pca_window - config_.window_max : samples;
  config_.search_lead = std::clamp(samples, 1, std::max(1, most));
  for (const auto& filter : filters_) filter->SetSearchLead(config_.search_lead);
}

bool MarkerPredictor::ready() const {
  for (const auto& f : filters_) {
    if (!f->ready()) return false;
  }
  return true;
}

}  // namespace nsim
