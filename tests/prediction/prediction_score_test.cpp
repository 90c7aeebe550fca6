// The online closed-loop score (PredictionScore) against the batch metrics of metrics.h as a
// second method: the same predictions, with the truth at the prediction times interpolated by
// ResampleLinear, give the same nRMS (NormalizedRmsError, eq. 4.20), RMS and bias. The
// shrinkage factor against known scalings of the true displacement and against a scan of the
// combined prediction's error over alpha.
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

// frames every 20 ms; after each, a prediction 3 frames ahead whose displacement is `gain`
// times the true one plus `off` (a displacement the markers never make)
void Feed(PredictionScore* score, int frames, double gain, const Eigen::Vector3d& off,
          int first = 0) {
  for (int k = first; k < first + frames; ++k) {
    const double t = 0.02 * k;
    const std::vector<Eigen::Vector3d> now = {Breath(t, 0), Breath(t, 1)};
    std::vector<Eigen::Vector3d> predicted(2);
    for (int m = 0; m < 2; ++m)
      predicted[m] = now[m] + gain * (Breath(t + 0.06, m) - now[m]) + (m == 1 ? off : Eigen::Vector3d::Zero());
    score->AddMeasurement(t, now);
    score->AddPrediction(t + 0.06, predicted, now);
  }
}

TEST(PredictionScoreTest, ShrinkageUndoesAScaledDisplacement) {
  for (const double gain : {1.0, 2.0, 4.0}) {
    PredictionScore score(50);
    Feed(&score, 200, gain, Eigen::Vector3d::Zero());
    const std::vector<double> alpha = score.Shrinkage();
    ASSERT_EQ(alpha.size(), 2u);
    EXPECT_NEAR(alpha[0], 1.0 / gain, 1e-12) << "gain " << gain;
    EXPECT_NEAR(alpha[1], 1.0 / gain, 1e-12) << "gain " << gain;
  }
  // never more than the predictor's own extrapolation, never negative
  PredictionScore under(50), reversed(50);
  Feed(&under, 200, 0.5, Eigen::Vector3d::Zero());
  Feed(&reversed, 200, -1.0, Eigen::Vector3d::Zero());
  EXPECT_EQ(under.Shrinkage()[0], 1.0);
  EXPECT_EQ(reversed.Shrinkage()[0], 0.0);
}

TEST(PredictionScoreTest, ShrinkageMinimizesTheCombinedError) {
  // marker 1's predictions carry a constant 0.3 mm the markers never move: part of each
  // prediction comes true, part does not; the factor is the minimum of a scan of the combined
  // prediction's squared error over the same 80 newest predictions
  const Eigen::Vector3d off(3e-4, -1e-4, 2e-4);
  PredictionScore score(80);
  Feed(&score, 400, 1.0, off);
  const double alpha = score.Shrinkage()[1];
  EXPECT_GT(alpha, 0.05);
  EXPECT_LT(alpha, 0.95);
  auto error = [&](double a) {  // the same 80 predictions: made at frames 317..396
    double sum = 0.0;
    for (int k = 317; k <= 396; ++k) {
      const double t = 0.02 * k;
      const Eigen::Vector3d change = Breath(t + 0.06, 1) - Breath(t, 1);
      sum += (a * (change + off) - change).squaredNorm();
    }
    return sum;
  };
  double best = 0.0, best_error = error(0.0);  // a scan by 1e-3, then by 1e-6 around its best
  for (double step : {1e-3, 1e-6}) {
    const double centre = best;
    for (int i = -1000; i <= 1000; ++i) {
      const double a = centre + i * step;
      if (a < 0.0 || a > 1.0) continue;
      const double e = error(a);
      if (e < best_error) best = a, best_error = e;
    }
  }
  EXPECT_NEAR(alpha, best, 2e-6);
  EXPECT_EQ(score.Shrinkage()[0], 1.0);  // marker 0's predictions are exact
}

TEST(PredictionScoreTest, ShrinkageForgetsAllButTheNewest) {
  PredictionScore score(40);
  Feed(&score, 300, 3.0, Eigen::Vector3d::Zero());
  EXPECT_NEAR(score.Shrinkage()[0], 1.0 / 3.0, 1e-12);
  Feed(&score, 43, 1.0, Eigen::Vector3d::Zero(), 300);  // 40 newer exact predictions scored
  EXPECT_NEAR(score.Shrinkage()[0], 1.0, 1e-12);
}

TEST(PredictionScoreTest, ShrinkageIsOneUntilAPredictionIsScored) {
  PredictionScore score(40);
  EXPECT_TRUE(score.Shrinkage().empty());
  Feed(&score, 3, 5.0, Eigen::Vector3d::Zero());  // nothing scored yet (3 frames ahead)
  EXPECT_EQ(score.scored(), 0u);
  EXPECT_EQ(score.Shrinkage(), std::vector<double>(2, 1.0));
}

}  // namespace
}  // namespace nsim
