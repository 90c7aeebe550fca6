#include "common/prediction/metrics.h"

#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

std::vector<double> UniformGrid(double t_begin, double t_end, double step) {
  if (!std::isfinite(t_begin) || !std::isfinite(t_end) || !(t_end >= t_begin))
    throw InputError(
        Str("uniform grid: expected finite t_begin <= t_end, got [", t_begin, ", ", t_end, "]"));
  if (!(step > 0) || !std::isfinite(step))
    throw InputError(Str("uniform grid: step must be > 0 (s), got ", step));
  const long n = static_cast<long>(std::floor((t_end - t_begin) / step + 1e-9)) + 1;
  std::vector<double> grid(n);
  for (long i = 0; i < n; ++i) grid[i] = t_begin + i * step;
  return grid;
}

Eigen::MatrixXd ResampleLinear(const std::vector<double>& t, const Eigen::MatrixXd& y,
                               const std::vector<double>& t_query) {
  const long n = static_cast<long>(t.size());
  if (n != y.rows())
    throw InputError(Str("resample: ", n, " times but ", y.rows(), " sample rows"));
  if (n < 2) throw InputError(Str("resample: needs >= 2 samples, got ", n));
  if (!y.allFinite()) throw InputError("resample: a sample value is not finite");
  for (long i = 0; i < n; ++i) {
    if (!std::isfinite(t[i])) throw InputError(Str("resample: time ", i, " is not finite"));
    if (i > 0 && !(t[i] > t[i - 1]))
      throw InputError(Str("resample: times must increase strictly; t[", i, "] = ", t[i],
                           " after t[", i - 1, "] = ", t[i - 1]));
  }
  const double slack = 1e-9 * (t[n - 1] - t[0]);
  Eigen::MatrixXd out(static_cast<long>(t_query.size()), y.cols());
  for (size_t q = 0; q < t_query.size(); ++q) {
    const double tq = t_query[q];
    if (!(tq >= t[0] - slack && tq <= t[n - 1] + slack))
      throw InputError(Str("resample: query time ", tq, " s outside the samples [", t[0], ", ",
                           t[n - 1], "] s"));
    // segment [t_k, t_k+1] containing tq
    long k = std::upper_bound(t.begin(), t.end(), tq) - t.begin() - 1;
    k = std::clamp(k, 0L, n - 2);
    const double w = std::clamp((tq - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0);
    out.row(static_cast<long>(q)) = (1 - w) * y.row(k) + w * y.row(k + 1);
  }
  return out;
}

double RmsError(const Eigen::MatrixXd& estimate, const Eigen::MatrixXd& reference) {
  if (estimate.rows() != reference.rows() || estimate.cols() != reference.cols() ||
      estimate.size() == 0)
    throw InputError(Str("RMS error: shapes differ or are empty (", estimate.rows(), "x",
                         estimate.cols(), " vs ", reference.rows(), "x", reference.cols(), ")"));
  return std::sqrt((estimate - reference).rowwise().squaredNorm().mean());
}

double NormalizedRmsError(const Eigen::MatrixXd& prediction, const Eigen::MatrixXd& delayed,
                          const Eigen::MatrixXd& reference) {
  const double denominator = RmsError(delayed, reference);
  if (!(denominator > 0))
    throw InputError(
        "nRMS: the delayed signal equals the reference (zero RMS), the ratio is undefined");
  return RmsError(prediction, reference) / denominator;
}

double Jitter(const Eigen::MatrixXd& series) {
  const long n = series.rows();
  if (n < 3) throw InputError(Str("jitter: needs >= 3 samples, got ", n));
  const Eigen::MatrixXd d2 =
      series.bottomRows(n - 2) - 2 * series.middleRows(1, n - 2) + series.topRows(n - 2);
  return std::sqrt(d2.rowwise().squaredNorm().mean());
}

double SignalPower(const Eigen::MatrixXd& y) {
  if (y.rows() == 0) throw InputError("signal power: empty series");
  const Eigen::RowVectorXd mean = y.colwise().mean();
  return (y.rowwise() - mean).rowwise().squaredNorm().mean();
}

}  // namespace nsim
