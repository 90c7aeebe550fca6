#include "common/breathing/marker_motion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

BreathingConfig ShortBreathing() {
  BreathingConfig c;
  c.horizon = 30;
  c.random_seed = 3;
  return c;
}

TEST(MarkerMotion, StreamHasTheConfiguredFramesTimesAndMarkers) {
  const BreathingModel model(ShortBreathing());
  MarkerMotionConfig config;
  config.duration = 10;
  config.rate = 30;
  const MarkerStream stream = MakeBreathingMarkerStream(model, config);
  EXPECT_EQ(stream.num_markers, 5);
  ASSERT_EQ(stream.frames.size(), 301u);
  for (size_t k = 0; k < stream.frames.size(); ++k) {
    EXPECT_EQ(stream.frames[k].stamp.seq, k);
    EXPECT_DOUBLE_EQ(stream.frames[k].stamp.sim_time, k / 30.0);
    EXPECT_EQ(stream.frames[k].p_WM.size(), 5u);
  }
}

TEST(MarkerMotion, MarkersStartInsideTheRegionAndMoveWithTheirGainAndTilt) {
  const BreathingModel model(ShortBreathing());
  MarkerMotionConfig config;
  config.num_markers = 12;
  config.region_center = Eigen::Vector3d(0.1, -0.05, 0.2);
  const MarkerMotion motion = MakeMarkerMotion(model, config);
  ASSERT_EQ(motion.p0_W.size(), 12u);
  for (int m = 0; m < 12; ++m) {
    const Eigen::Vector3d u =
        (motion.p0_W[m] - config.region_center).cwiseQuotient(config.region_semi_axes);
    EXPECT_LE(u.norm(), 1.0);
    EXPECT_GE(motion.gain[m], config.min_gain);
    EXPECT_LE(motion.gain[m], config.max_gain);
    // ||p - p0|| = g ||d|| and the direction is tilted by at most max_tilt
    for (double t : {0.7, 1.9, 2.3}) {
      const Eigen::Vector3d d = model.CalcDisplacement(t);
      const Eigen::Vector3d moved = CalcMarkerPosition(model, motion, m, t) - motion.p0_W[m];
      EXPECT_NEAR(moved.norm(), motion.gain[m] * d.norm(), 1e-12);
      const double angle =
          std::acos(std::clamp(moved.dot(d) / (moved.norm() * d.norm()), -1.0, 1.0));
      EXPECT_LE(angle, config.max_tilt + 1e-9);
    }
  }
  // deeper (more superior, +z by default) markers move more
  for (int a = 0; a < 12; ++a) {
    for (int b = 0; b < 12; ++b) {
      if (motion.p0_W[a].z() > motion.p0_W[b].z()) {
        EXPECT_GT(motion.gain[a], motion.gain[b]);
      }
    }
  }
}

TEST(MarkerMotion, SameSeedSameStreamOtherSeedOtherPlacement) {
  const BreathingModel model(ShortBreathing());
  MarkerMotionConfig config;
  config.duration = 2;
  const MarkerStream a = MakeBreathingMarkerStream(model, config);
  const MarkerStream b = MakeBreathingMarkerStream(model, config);
  config.random_seed = 99;
  const MarkerStream c = MakeBreathingMarkerStream(model, config);
  for (size_t k = 0; k < a.frames.size(); ++k) {
    for (int m = 0; m < 5; ++m) EXPECT_EQ(a.frames[k].p_WM[m], b.frames[k].p_WM[m]);
  }
  EXPECT_GT((a.frames[0].p_WM[0] - c.frames[0].p_WM[0]).norm(), 1e-3);
}

TEST(MarkerMotion, BadInputNamesTheField) {
  const BreathingModel model(ShortBreathing());
  MarkerMotionConfig config;
  config.rate = 0;
  try {
    MakeBreathingMarkerStream(model, config);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "markers.rate must be > 0 (Hz), got 0");
  }
  config = MarkerMotionConfig();
  config.duration = 100;  // beyond the 30 s horizon
  try {
    MakeBreathingMarkerStream(model, config);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds the breathing model horizon"), std::string::npos);
  }
  config = MarkerMotionConfig();
  config.max_gain = 0.5;
  EXPECT_THROW(config.Validate(), InputError);
  config = MarkerMotionConfig();
  config.num_markers = 0;
  EXPECT_THROW(config.Validate(), InputError);
}

}  // namespace
}  // namespace nsim
