// The online closed-loop score (PredictionScore) against the batch metrics of metrics.h as a
// second method: the same predictions, with the truth at the prediction times interpolated by
// ResampleLinear, give the same nRMS (NormalizedRmsError, eq. 4.20), RMS and bias.
#include "common/prediction/prediction_score.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/prediction/metrics.h"

namespace nsim {
namespace {

Eigen::Vector3d Breath(double t, int m) {
  const double s = std::pow(std::cos(M_PI * t / 4.0), 4);
  return Eigen::Vector3d(0.001 * m + 0.0013 * s, 0.0038 * s, -0.012 * s);
}

// frames at a jittered rate; a prediction after each frame for t + horizon, equal to the truth
// plus a seeded error
void CheckAgainstBatch(double horizon, uint64_t seed) {
  const int markers = 3;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(0.015, 0.025);
  std::normal_distribution<double> noise(0.0, 2e-4);
  std::vector<double> t = {0.0};
  while (t.size() < 400) t.push_back(t.back() + jitter(rng));

  PredictionScore score;
  struct Made {
    double t_for;
    std::vector<Eigen::Vector3d> predicted, measured;
  };
  std::vector<Made> made;
  for (size_t k = 0; k < t.size(); ++k) {
    std::vector<Eigen::Vector3d> now(markers), predicted(markers);
    for (int m = 0; m < markers; ++m) {
      now[m] = Breath(t[k], m);
      predicted[m] = Breath(t[k] + horizon, m) + Eigen::Vector3d(noise(rng), noise(rng), 1e-4);
    }
    score.AddMeasurement(t[k], now);
    score.AddPrediction(t[k] + horizon, predicted, now);
    made.push_back({t[k] + horizon, predicted, now});
  }
  // the batch: every prediction whose time lies within the stream (the ones the score saw
  // bracketed), truth interpolated from the measured frames
  std::vector<double> t_query;
  for (const Made& e : made)
    if (e.t_for <= t.back()) t_query.push_back(e.t_for);
  ASSERT_EQ(score.scored(), t_query.size());
  const std::vector<std::optional<double>> nrms = score.NrmsPercent();
  const std::vector<double> rms = score.Rms();
  const std::vector<Eigen::Vector3d> bias = score.Bias();
  ASSERT_EQ(nrms.size(), static_cast<size_t>(markers));
  for (int m = 0; m < markers; ++m) {
    Eigen::MatrixXd y(t.size(), 3);
    for (size_t k = 0; k < t.size(); ++k) y.row(k) = Breath(t[k], m).transpose();
    const Eigen::MatrixXd reference = ResampleLinear(t, y, t_query);
    Eigen::MatrixXd prediction(t_query.size(), 3), delayed(t_query.size(), 3);
    for (size_t i = 0; i < t_query.size(); ++i) {
      prediction.row(i) = made[i].predicted[m].transpose();
      delayed.row(i) = made[i].measured[m].transpose();
    }
    ASSERT_TRUE(nrms[m].has_value());
    EXPECT_NEAR(*nrms[m], 100.0 * NormalizedRmsError(prediction, delayed, reference), 1e-9)
        << "marker " << m << ", horizon " << horizon;
    EXPECT_NEAR(rms[m], RmsError(prediction, reference), 1e-12);
    const Eigen::Vector3d mean_error = (prediction - reference).colwise().mean().transpose();
    EXPECT_LT((bias[m] - mean_error).norm(), 1e-12);
  }
}

TEST(PredictionScoreTest, EqualsBatchNrmsAtAHorizonOfOneFrame) { CheckAgainstBatch(0.02, 1); }
TEST(PredictionScoreTest, EqualsBatchNrmsAtAHorizonOfSeveralFrames) { CheckAgainstBatch(0.1, 2); }
TEST(PredictionScoreTest, EqualsBatchNrmsAtAHorizonBetweenFrames) { CheckAgainstBatch(0.0537, 3); }

TEST(PredictionScoreTest, NotPredictingScoresOneHundredPercent) {
  PredictionScore score;
  for (int k = 0; k < 100; ++k) {
    const double t = 0.02 * k;
    const std::vector<Eigen::Vector3d> now = {Breath(t, 0)};
    score.AddMeasurement(t, now);
    score.AddPrediction(t + 0.06, now, now);  // the prediction is the delayed measurement
  }
  ASSERT_GT(score.scored(), 90u);
  EXPECT_NEAR(*score.NrmsPercent()[0], 100.0, 1e-9);
}

TEST(PredictionScoreTest, AStillStreamHasNoNrms) {
  PredictionScore score;
  const std::vector<Eigen::Vector3d> still = {Eigen::Vector3d(0.01, 0, 0)};
  for (int k = 0; k < 10; ++k) {
    score.AddMeasurement(0.02 * k, still);
    score.AddPrediction(0.02 * k + 0.02, still, still);
  }
  EXPECT_FALSE(score.NrmsPercent()[0].has_value());
  EXPECT_EQ(score.Rms()[0], 0.0);
}

}  // namespace
}  // namespace nsim
