#pragma once
// Prediction metrics (thesis §4.1.5): uniform resampling, RMS (eq. 4.19), nRMS (eq. 4.20) and
// jitter. Series are matrices with one row per sample and one column per coordinate
// (#samples x d); the thesis applies the metrics to the first principal component (d = 1), this
// project reports them on 3D positions (d = 3): the error of a sample is the Euclidean norm of
// the position difference.

#include <Eigen/Core>
#include <vector>

namespace nsim {

/// t_begin, t_begin + step, ... up to t_end (inclusive within 1e-9 step) (s). Throws
/// InputError unless step > 0, t_end >= t_begin and both are finite.
std::vector<double> UniformGrid(double t_begin, double t_end, double step);

/// Linear interpolation of the samples (t_i, row i of y) at each query time; returns
/// #queries x y.cols(). Throws InputError if t is not strictly increasing or not finite, sizes
/// differ, there are fewer than 2 samples, y has a non-finite value, or a query lies outside
/// [t_0, t_{n-1}] (by more than 1e-9 of the span).
Eigen::MatrixXd ResampleLinear(const std::vector<double>& t, const Eigen::MatrixXd& y,
                               const std::vector<double>& t_query);

/// RMS error, eq. 4.19: sqrt(mean_i ||estimate_i - reference_i||^2) (units of the series).
/// Throws InputError if the shapes differ or are empty.
double RmsError(const Eigen::MatrixXd& estimate, const Eigen::MatrixXd& reference);

/// nRMS, eq. 4.20: RmsError(prediction, reference) / RmsError(delayed, reference), where
/// `delayed` is the measured signal delayed by the horizon (the no-prediction output) (-).
/// 1 means no better than not predicting. Throws InputError if the denominator is 0.
double NormalizedRmsError(const Eigen::MatrixXd& prediction, const Eigen::MatrixXd& delayed,
                          const Eigen::MatrixXd& reference);

/// Jitter of a uniformly sampled series: the RMS norm of its second difference,
/// sqrt(mean_i ||y_{i+1} - 2 y_i + y_{i-1}||^2) (units of the series, at the series' step).
/// A smooth breathing curve at 30 Hz has ~10 um; noise of std s per coordinate adds
/// sqrt(6 d) s. Throws InputError for fewer than 3 samples.
double Jitter(const Eigen::MatrixXd& series);

/// Signal power of a series: mean_i ||y_i - mean(y)||^2 (units^2), the total over coordinates.
double SignalPower(const Eigen::MatrixXd& y);

}  // namespace nsim
