#pragma once
// Online scoring of marker predictions in the closed loop (thesis §4.1.7, eq. 4.19-4.20): each
// prediction made at t for t + h is compared with the measured stream at t + h, linearly
// interpolated between the two frames around it; the no-prediction baseline is the frame
// measured at t (the measurement delayed by h). nRMS = RMS(prediction) / RMS(baseline), the
// definition of NormalizedRmsError (metrics.h) evaluated at the prediction times instead of on
// a uniform grid. The error of a sample is the norm of the 3D position difference.
//
// It also measures, over the most recent scored predictions, how much of each predicted
// displacement came true: the least-squares factor alpha of the combination
// baseline + alpha (prediction - baseline) (a combination of forecasts, Bates & Granger 1969,
// the second one being "no change"). alpha = 1: the prediction is used as it is; 0: it carries
// nothing the delayed measurement does not (or it amplifies what it cannot predict, e.g. a
// quadratic through 3 noise-free samples extrapolated 10 frames ahead multiplies a 0.1 mm
// disturbance by ~170).

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

namespace nsim {

class PredictionScore {
 public:
  /// recent: how many of the newest scored predictions Shrinkage() uses (0: none kept).
  explicit PredictionScore(int recent = 0);

  /// A prediction, made from the frame measured at some t, of the markers at t_for = t + h;
  /// `measured_now` is that frame (the baseline). Same marker count as the stream.
  void AddPrediction(double t_for, std::vector<Eigen::Vector3d> predicted,
                     std::vector<Eigen::Vector3d> measured_now);
  /// A measured frame, at strictly increasing times; scores the predictions whose t_for it
  /// brackets with the previous frame.
  void AddMeasurement(double t, const std::vector<Eigen::Vector3d>& p_WM);

  /// Predictions scored so far.
  uint64_t scored() const { return scored_; }
  /// Per marker: 100 RMS(pred) / RMS(baseline) (%), empty optional when the baseline RMS is 0.
  std::vector<std::optional<double>> NrmsPercent() const;
  /// Per marker: RMS of the prediction error (m).
  std::vector<double> Rms() const;
  /// Per marker: mean prediction error (predicted - measured) in world axes (m).
  std::vector<Eigen::Vector3d> Bias() const;
  /// Per marker: the least-squares factor alpha minimizing sum |baseline + alpha (predicted -
  /// baseline) - measured|^2 over the newest `recent` scored predictions, clamped to [0, 1]
  /// (never more than the predictor's own extrapolation); 1 before any is scored or when the
  /// predictions did not move. Same size as the stream's markers (empty before a measurement).
  std::vector<double> Shrinkage() const;

 private:
  struct Pending {
    double t_for;
    std::vector<Eigen::Vector3d> predicted, measured;
  };
  // per marker, the newest scored (predicted - baseline) . (measured - baseline) and
  // |predicted - baseline|^2, a ring of `recent_` entries each
  struct Recent {
    std::vector<double> cross, square;
    int next = 0, count = 0;
  };
  int recent_;
  std::vector<Recent> recent_terms_;
  std::deque<Pending> pending_;
  std::vector<double> pred_sq_, base_sq_;
  std::vector<Eigen::Vector3d> pred_sum_;
  double last_t_ = 0.0;
  std::vector<Eigen::Vector3d> last_p_;
  bool has_last_ = false;
  uint64_t scored_ = 0;
};

}  // namespace nsim
