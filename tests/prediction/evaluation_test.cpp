#include "common/prediction/evaluation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/breathing/breathing.h"
#include "common/breathing/marker_motion.h"
#include "common/core/error.h"

namespace nsim {
namespace {

MarkerStream BreathingStream(double duration, int markers, uint64_t seed) {
  BreathingConfig b;
  b.horizon = duration + 10;
  b.random_seed = seed;
  MarkerMotionConfig m;
  m.duration = duration;
  m.num_markers = markers;
  m.random_seed = seed;
  return MakeBreathingMarkerStream(BreathingModel(b), m);
}

PredictionConfig Config(PredictionFilterKind kind) {
  PredictionConfig c;
  c.filter = kind;
  c.pca_window = 150;
  c.window_max = 40;
  return c;
}

// measured SNR = 10 log10(P / noise power); the noise power of N frames x 3 coordinates has a
// relative std of sqrt(2 / (3 N)): allow 4 of them
TEST(AddWhiteNoise, MeasuresBackAtTheRequestedSnr) {
  const MarkerStream clean = BreathingStream(100, 3, 1);
  const double n = clean.frames.size();
  const double tolerance_db = 4 * 10 / std::log(10.0) * std::sqrt(2 / (3 * n));
  for (double snr : {60.0, 40.0, 20.0, 0.0}) {
    const MarkerStream noisy = AddWhiteNoise(clean, snr, 5);
    for (int m = 0; m < 3; ++m)
      EXPECT_NEAR(MeasureSnrDb(clean, noisy, m), snr, tolerance_db) << snr;
  }
  // the same seed scales the same draws: 20 dB apart is a factor 10 in amplitude
  const MarkerStream a = AddWhiteNoise(clean, 40, 5), b = AddWhiteNoise(clean, 20, 5);
  const Eigen::Vector3d na = a.frames[7].p_WM[1] - clean.frames[7].p_WM[1];
  const Eigen::Vector3d nb = b.frames[7].p_WM[1] - clean.frames[7].p_WM[1];
  EXPECT_NEAR((nb - 10 * na).norm(), 0, 1e-9 * nb.norm());
  // no noise at +inf; another seed, other noise
  EXPECT_EQ(AddWhiteNoise(clean, INFINITY, 5).frames[3].p_WM[0], clean.frames[3].p_WM[0]);
  EXPECT_NE(AddWhiteNoise(clean, 40, 6).frames[3].p_WM[0], a.frames[3].p_WM[0]);
  EXPECT_THROW(AddWhiteNoise(clean, std::nan(""), 5), InputError);
}

TEST(EvaluatePrediction, NoPredictionScoresExactlyOneHundredPercent) {
  const MarkerStream clean = BreathingStream(30, 2, 2);
  const MarkerStream noisy = AddWhiteNoise(clean, 30, 3);
  for (double h : {0.1, 0.4}) {
    const PredictionEvaluation e =
        EvaluatePrediction(noisy, clean, Config(PredictionFilterKind::kNone), h);
    for (const auto& m : e.markers) {
      EXPECT_DOUBLE_EQ(m.nrms, 1.0);
      EXPECT_DOUBLE_EQ(m.rms, m.rms_delayed);
    }
  }
}

TEST(EvaluatePrediction, FiltersBeatNoPredictionOnCleanBreathing) {
  const MarkerStream clean = BreathingStream(60, 3, 4);
  for (PredictionFilterKind kind :
       {PredictionFilterKind::kLinear, PredictionFilterKind::kHarmonicKalman}) {
    const PredictionEvaluation e = EvaluatePrediction(clean, clean, Config(kind), 0.2);
    EXPECT_EQ(e.first_ready_frame, 149);
    EXPECT_NEAR(e.t_grid.front(), clean.frames[149].stamp.sim_time + 0.2, 1e-12);
    for (const auto& m : e.markers) {
      EXPECT_LT(m.nrms, 0.5) << ToString(kind);
      EXPECT_GT(m.rms_delayed, 1e-4);  // the signal does move by 0.1 mm and more over 0.2 s
      if (kind == PredictionFilterKind::kLinear) {
        EXPECT_GE(m.window, 3);
        EXPECT_LE(m.window, 39);
      }
    }
  }
}

TEST(EvaluatePrediction, BadInputThrowsInputError) {
  const MarkerStream clean = BreathingStream(10, 2, 2);
  auto message = [&](const MarkerStream& measured, PredictionConfig c, double h) -> std::string {
    try {
      EvaluatePrediction(measured, clean, c, h);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const PredictionConfig lf = Config(PredictionFilterKind::kLinear);
  EXPECT_EQ(message(clean, lf, -0.1), "prediction horizon must be >= 0 and finite (s), got -0.1");
  MarkerStream shifted = clean;
  shifted.frames[5].stamp.sim_time += 0.001;
  EXPECT_EQ(message(shifted, lf, 0.1).rfind("evaluation: frame 5 time differs", 0), 0u);
  PredictionConfig long_buffer = lf;
  long_buffer.pca_window = 300;  // 10 s at 30 Hz: never ready in a 10 s stream
  EXPECT_NE(message(clean, long_buffer, 0.1).find("is too short for filter lf"), std::string::npos);
  EXPECT_NE(message(clean, lf, 6.0).find("is too short"), std::string::npos);
}

}  // namespace
}  // namespace nsim
