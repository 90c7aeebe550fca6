#pragma once
// Offline evaluation of marker prediction (thesis §5.2.1): measurement noise at a given SNR,
// a causal run of a MarkerPredictor over a recorded stream, and the metrics of metrics.h on a
// uniform grid.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/markers/marker_csv.h"
#include "common/prediction/marker_predictor.h"

namespace nsim {

/// Positions of marker m over the stream (#frames x 3, m).
Eigen::MatrixXd MarkerTrajectory(const MarkerStream& stream, int m);
/// Frame times of the stream (s).
std::vector<double> FrameTimes(const MarkerStream& stream);

/// Adds white Gaussian noise, independent per frame, marker and coordinate. For marker m with
/// signal power P_m = SignalPower(trajectory) (mean squared norm of the centred positions, m^2),
/// each coordinate gets std sigma_m = sqrt(P_m / (3 * 10^(snr_db / 10))), so the total noise
/// power is P_m / 10^(snr_db / 10). snr_db = +inf returns an exact copy. Seeded
/// (std::mt19937_64): the same seed gives the same standard-normal draws for every SNR. Throws
/// InputError for a NaN or -inf SNR.
MarkerStream AddWhiteNoise(const MarkerStream& clean, double snr_db, uint64_t seed);

/// Measured SNR of marker m (dB): 10 log10(P_m(clean) / mean ||noisy - clean||^2).
double MeasureSnrDb(const MarkerStream& clean, const MarkerStream& noisy, int m);

/// Metrics and resampled series of one marker.
struct MarkerEvaluation {
  double rms = 0.0;           ///< eq. 4.19 on the 3D error of the prediction vs reference (m)
  double rms_delayed = 0.0;   ///< the same for the measurement delayed by the horizon (m)
  double nrms = 0.0;          ///< rms / rms_delayed, eq. 4.20 (-)
  double jitter = 0.0;        ///< Jitter() of the resampled prediction (m)
  int window = 0;             ///< WF at the end of the run (samples); 0 without a regression window
  Eigen::MatrixXd reference;  ///< reference on the grid (#grid x 3, m)
  Eigen::MatrixXd predicted;  ///< prediction targeting each grid time (#grid x 3, m)
  Eigen::MatrixXd delayed;    ///< measurement delayed by the horizon (#grid x 3, m)
};

/// Result of EvaluatePrediction.
struct PredictionEvaluation {
  double horizon = 0.0;        ///< h (s)
  int first_ready_frame = 0;   ///< first frame after which the predictor was ready
  std::vector<double> t_grid;  ///< uniform grid of target times (s)
  std::vector<MarkerEvaluation> markers;
};

/// Runs a MarkerPredictor causally over `measured`: after frame k (time t_k) it predicts the
/// positions at t_k + h. Once the predictor is ready (frame k0), the predictions (at t_k + h)
/// and the no-prediction output (the measurement y_k, also placed at t_k + h: the delayed
/// signal D(y, h) of eq. 4.20) are resampled by linear interpolation on a uniform grid from
/// t_k0 + h to the last frame time, step = the mean frame interval, and compared with
/// `reference` (the noise-free positions, interpolated on the same grid). With filter "none"
/// nRMS is exactly 1. Throws InputError if the streams differ in markers, frames or times,
/// h < 0 or not finite, or the stream is too short for the filter's warm-up and h.
PredictionEvaluation EvaluatePrediction(const MarkerStream& measured, const MarkerStream& reference,
                                        const PredictionConfig& config, double horizon);

}  // namespace nsim
