#include "common/control/path_targets.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kSwitch = 0.002;  // m

std::vector<Eigen::Vector3d> StraightPath() {
  return {{0, 0, 0.10}, {0, 0, 0.07}, {0, 0, 0.04}, {0, 0, 0.01}};
}

TEST(PathTargets, SwitchesWhenWithinTheDistance) {
  PathTargetConfig config;
  config.switch_distance = kSwitch;
  PathTargetTracker tracker(StraightPath(), config);
  EXPECT_EQ(tracker.index(), 0);
  EXPECT_EQ(tracker.Update({0, 0, 0.12}), 0);         // 2 cm away
  EXPECT_EQ(tracker.Update({0.0015, 0, 0.1015}), 0);  // 2.1 mm away
  EXPECT_EQ(tracker.Update({0.001, 0, 0.101}), 1);    // 1.4 mm: next point
  EXPECT_EQ(tracker.target(), Eigen::Vector3d(0, 0, 0.07));
  EXPECT_EQ(tracker.Update({0, 0, 0.0999}), 0);  // never goes back
  EXPECT_EQ(tracker.index(), 1);
  EXPECT_FALSE(tracker.reached_end());
}

TEST(PathTargets, PassesSeveralPointsAndStopsAtTheEnd) {
  PathTargetConfig config;
  config.switch_distance = 0.065;
  PathTargetTracker tracker(StraightPath(), config);
  // from z = 0.04 every point is within 6.5 cm: passes 0 -> 1 -> 2 -> 3 in one update
  EXPECT_EQ(tracker.Update({0, 0, 0.04}), 3);
  EXPECT_EQ(tracker.index(), 3);
  EXPECT_TRUE(tracker.reached_end());
  EXPECT_EQ(tracker.Update({0, 0, 0.01}), 0);
  EXPECT_EQ(tracker.index(), 3);
}

TEST(PathTargets, DirectionsAndFaults) {
  PathTargetTracker tracker(StraightPath(), PathTargetConfig());
  EXPECT_LT((tracker.CalcDirection(0) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_LT((tracker.CalcDirection(3) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_EQ(tracker.Update(Eigen::Vector3d(std::nan(""), 0, 0)), 0);
  PathTargetTracker single({{0, 0, 0}}, PathTargetConfig());
  EXPECT_TRUE(single.CalcDirection(0).hasNaN());
  EXPECT_THROW(PathTargetTracker({}, PathTargetConfig()), InputError);
  EXPECT_THROW(PathTargetTracker({{0, std::nan(""), 0}}, PathTargetConfig()), InputError);
  PathTargetConfig bad;
  bad.switch_distance = 0.0;
  try {
    bad.Validate();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "control.path.switch_distance must be > 0 (m), got 0");
  }
}

}  // namespace
}  // namespace nsim
