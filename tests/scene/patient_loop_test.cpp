// The patient loop without transport: frames are numbered and timed, a controller in this test
// drives it in-process; checked against the no-controller insertion (a second method: a
// controller that commands the planned path must give the same trajectory, bit for bit), the
// gate's hold, and the lockstep latency rule.
#include "common/scene/patient_loop.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/core/error.h"
#include "common/scene/lockstep_targets.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

PatientLoop MakeLoop(const DirectScenario& s, bool controller) {
  return PatientLoop(s.LoopConfig(controller), s.liver_mesh, s.skin_mesh);
}

// the no-controller insertion's command for the step from t (flange on the path at speed)
RobotTarget PathTarget(const PatientLoop& loop, const SensorFrame& frame) {
  const InsertionConfig& ins = loop.config().insertion;
  const double h = loop.config().scene.time_step;
  const double s = std::min(ins.speed * (frame.stamp.sim_time + h),
                            loop.plan().total_travel() + ins.overshoot);
  RobotTarget t;
  t.answers_seq = frame.stamp.seq;
  t.stamp.sim_time = frame.stamp.sim_time;
  t.X_WE = loop.plan().CalcFlangePose(s);
  return t;
}

TEST(PatientLoopTest, FramesAreNumberedAndTimed) {
  const DirectScenario s = testing::LoadCoarseScenario();
  PatientLoop loop = MakeLoop(s, false);
  EXPECT_EQ(loop.frame().stamp.seq, 0u);
  EXPECT_EQ(loop.frame().p_WM.size(), s.scene.markers_W.size());
  EXPECT_TRUE(loop.frame().has_robot);
  for (int k = 1; k <= 5; ++k) {
    const SensorFrame& f = loop.Step();
    EXPECT_EQ(f.stamp.seq, static_cast<uint64_t>(k));
    EXPECT_NEAR(f.stamp.sim_time, k * s.scene.time_step, 1e-12);
    EXPECT_TRUE(loop.healthy()) << loop.fault();
  }
  EXPECT_EQ(loop.steps(), 5);
}

TEST(PatientLoopTest, AControllerCommandingThePlannedPathEqualsTheNoControllerInsertion) {
  DirectScenario s = testing::LoadCoarseScenario();
  s.insertion.speed = 0.03;
  PatientLoop plain = MakeLoop(s, false), driven = MakeLoop(s, true);
  for (int k = 0; k < 60; ++k) {
    plain.Step();
    driven.Step(PathTarget(driven, driven.frame()));
    ASSERT_FALSE(driven.last_step().holding) << "step " << k;
  }
  EXPECT_EQ(driven.gate().counts().accepted, 60u);
  EXPECT_EQ(driven.record().tip, plain.record().tip);
  EXPECT_EQ(driven.frame().X_WE.matrix(), plain.frame().X_WE.matrix());
  for (size_t m = 0; m < plain.frame().p_WM.size(); ++m)
    EXPECT_EQ(driven.frame().p_WM[m], plain.frame().p_WM[m]) << "marker " << m;
  EXPECT_GT(plain.record().phase, 0);  // 0.03 m/s for 1.2 s: through the 1 cm approach
}

TEST(PatientLoopTest, TheRobotHoldsWithoutTargetsAndWhenTheControllerIsLost) {
  const DirectScenario s = testing::LoadCoarseScenario();
  PatientLoop loop = MakeLoop(s, true);
  loop.Step();
  EXPECT_TRUE(loop.last_step().holding);  // no command yet
  loop.Step(PathTarget(loop, loop.frame()));
  EXPECT_FALSE(loop.last_step().holding);
  // no further target: after safety.hold_timeout it holds
  const int hold_steps = static_cast<int>(s.safety.hold_timeout / s.scene.time_step) + 2;
  for (int k = 0; k < hold_steps; ++k) loop.Step();
  EXPECT_TRUE(loop.last_step().holding);
  // a controller marked lost is not obeyed
  loop.set_controller_lost(true);
  const Eigen::Isometry3d before = loop.frame().X_WE;
  loop.Step(PathTarget(loop, loop.frame()));
  EXPECT_TRUE(loop.last_step().holding);
  EXPECT_TRUE(loop.frame().X_WE.isApprox(before, 1e-9));
}

TEST(PatientLoopTest, LockstepLatencyAppliesTheAnswerToFrameKMinusD) {
  LockstepTargets delay(2);
  EXPECT_TRUE(delay.Ready(0));
  EXPECT_TRUE(delay.Ready(1));
  EXPECT_FALSE(delay.TakeFor(1).has_value());  // k < d: nothing to apply yet
  RobotTarget t;
  for (uint64_t seq : {0u, 1u, 2u}) {
    t.answers_seq = seq;
    delay.Add(t);
  }
  EXPECT_TRUE(delay.Ready(2));
  EXPECT_TRUE(delay.Ready(4));   // an answer to frame 2 = 4 - d is here
  EXPECT_FALSE(delay.Ready(5));  // frame 3 not answered yet: step 5 must wait
  const std::optional<RobotTarget> at2 = delay.TakeFor(2);
  ASSERT_TRUE(at2.has_value());
  EXPECT_EQ(at2->answers_seq, 0u);
  const std::optional<RobotTarget> at4 = delay.TakeFor(4);  // the newest <= 2; 1 is dropped
  ASSERT_TRUE(at4.has_value());
  EXPECT_EQ(at4->answers_seq, 2u);
  EXPECT_EQ(delay.pending(), 0u);
  t.answers_seq = 9;  // an answer to a frame newer than k - d is kept for later
  delay.Add(t);
  EXPECT_FALSE(delay.TakeFor(5).has_value());
  EXPECT_EQ(delay.pending(), 1u);
  EXPECT_THROW(LockstepTargets(-1), InputError);
}

// The tracker's noise is on the published markers only: the physics, the record and the
// watchdog see the exact state (a loop without noise steps to the same state, bit for bit),
// the published markers differ from the exact ones by noise of the configured size, and the
// run's seed decides the draws.
TEST(PatientLoopTest, TheTrackersNoiseIsOnThePublishedMarkersOnly) {
  DirectScenario s = testing::LoadCoarseScenario();
  s.tracker.marker_std = 3e-4;
  DirectScenario exact_s = s, other_s = s;
  exact_s.tracker.marker_std = 0.0;
  other_s.random_seed = s.random_seed + 1;
  PatientLoop noisy = MakeLoop(s, false), again = MakeLoop(s, false);
  PatientLoop exact = MakeLoop(exact_s, false), other = MakeLoop(other_s, false);
  double sum2 = 0.0;
  int draws = 0;
  bool seed_matters = false;
  for (int k = 0; k < 20; ++k) {
    noisy.Step();
    again.Step();
    exact.Step();
    other.Step();
    ASSERT_TRUE(noisy.healthy()) << noisy.fault();
    EXPECT_EQ(noisy.record().target, exact.record().target);
    EXPECT_EQ(noisy.record().tip, exact.record().tip);
    std::vector<Eigen::Vector3d> truth;
    noisy.scene().CalcMarkerPositions(&truth);
    ASSERT_EQ(noisy.frame().p_WM.size(), truth.size());
    for (size_t m = 0; m < truth.size(); ++m) {
      EXPECT_EQ(exact.frame().p_WM[m], truth[m]);
      EXPECT_EQ(noisy.frame().p_WM[m], again.frame().p_WM[m]);
      seed_matters = seed_matters || other.frame().p_WM[m] != noisy.frame().p_WM[m];
      sum2 += (noisy.frame().p_WM[m] - truth[m]).squaredNorm();
      draws += 3;
    }
  }
  EXPECT_TRUE(seed_matters);
  // 300 draws: the sample standard deviation is within 4 % (one standard error) of sigma;
  // 25 % is six standard errors
  EXPECT_NEAR(std::sqrt(sum2 / draws), 3e-4, 0.25 * 3e-4);
}

}  // namespace
}  // namespace nsim
