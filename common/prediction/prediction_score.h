#pragma once
// Online scoring of marker predictions in the closed loop (thesis §4.1.7, eq. 4.19-4.20): each
// prediction made at t for t + h is compared with the measured stream at t + h, linearly
// interpolated between the two frames around it; the no-prediction baseline is the frame
// measured at t (the measurement delayed by h). nRMS = RMS(prediction) / RMS(baseline), the
// definition of NormalizedRmsError (metrics.h) evaluated at the prediction times instead of on
// a uniform grid. The error of a sample is the norm of the 3D position difference.

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

namespace nsim {

class PredictionScore {
 public:
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

 private:
  struct Pending {
    double t_for;
    std::vector<Eigen::Vector3d> predicted, measured;
  };
  std::deque<Pending> pending_;
  std::vector<double> pred_sq_, base_sq_;
  std::vector<Eigen::Vector3d> pred_sum_;
  double last_t_ = 0.0;
  std::vector<Eigen::Vector3d> last_p_;
  bool has_last_ = false;
  uint64_t scored_ = 0;
};

}  // namespace nsim
