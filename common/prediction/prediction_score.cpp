#include "common/prediction/prediction_score.h"

#include <algorithm>
#include <cmath>

namespace nsim {

PredictionScore::PredictionScore(int recent) : recent_(std::max(0, recent)) {}

void PredictionScore::AddPrediction(double t_for, std::vector<Eigen::Vector3d> predicted,
                                    std::vector<Eigen::Vector3d> measured_now) {
  pending_.push_back({t_for, std::move(predicted), std::move(measured_now)});
}

void PredictionScore::AddMeasurement(double t, const std::vector<Eigen::Vector3d>& p) {
  if (pred_sq_.size() != p.size()) {
    pred_sq_.assign(p.size(), 0.0);
    base_sq_.assign(p.size(), 0.0);
    pred_sum_.assign(p.size(), Eigen::Vector3d::Zero());
    recent_terms_.assign(p.size(), Recent{std::vector<double>(recent_), std::vector<double>(recent_)});
  }
  while (!pending_.empty() && pending_.front().t_for <= t + 1e-9) {
    const Pending& e = pending_.front();
    // a prediction for a time before the previous frame cannot be bracketed: not scored
    if (has_last_ && e.t_for >= last_t_ - 1e-9 && e.predicted.size() == p.size() &&
        e.measured.size() == p.size()) {
      const double span = t - last_t_;
      const double a = span > 0 ? std::clamp((e.t_for - last_t_) / span, 0.0, 1.0) : 1.0;
      for (size_t m = 0; m < p.size(); ++m) {
        const Eigen::Vector3d truth = (1.0 - a) * last_p_[m] + a * p[m];
        pred_sq_[m] += (e.predicted[m] - truth).squaredNorm();
        pred_sum_[m] += e.predicted[m] - truth;
        base_sq_[m] += (e.measured[m] - truth).squaredNorm();
        if (recent_ > 0) {
          Recent& r = recent_terms_[m];
          const Eigen::Vector3d predicted_change = e.predicted[m] - e.measured[m];
          r.cross[r.next] = predicted_change.dot(truth - e.measured[m]);
          r.square[r.next] = predicted_change.squaredNorm();
          r.next = (r.next + 1) % recent_;
          r.count = std::min(r.count + 1, recent_);
        }
      }
      ++scored_;
    }
    pending_.pop_front();
  }
  last_t_ = t;
  last_p_ = p;
  has_last_ = true;
}

std::vector<std::optional<double>> PredictionScore::NrmsPercent() const {
  std::vector<std::optional<double>> out;
  for (size_t m = 0; m < pred_sq_.size(); ++m)
    out.push_back(base_sq_[m] > 0 ? std::optional<double>(100.0 * std::sqrt(pred_sq_[m] / base_sq_[m]))
                                  : std::nullopt);
  return out;
}

std::vector<double> PredictionScore::Shrinkage() const {
  std::vector<double> out;
  for (const Recent& r : recent_terms_) {
    double cross = 0.0, square = 0.0;
    for (int i = 0; i < r.count; ++i) {
      cross += r.cross[i];
      square += r.square[i];
    }
    out.push_back(square > 0 ? std::clamp(cross / square, 0.0, 1.0) : 1.0);
  }
  return out;
}

std::vector<double> PredictionScore::Rms() const {
  std::vector<double> out;
  for (double sq : pred_sq_) out.push_back(scored_ ? std::sqrt(sq / scored_) : 0.0);
  return out;
}

std::vector<Eigen::Vector3d> PredictionScore::Bias() const {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& sum : pred_sum_)
    out.push_back(scored_ ? Eigen::Vector3d(sum / static_cast<double>(scored_))
                          : Eigen::Vector3d::Zero());
  return out;
}

}  // namespace nsim
