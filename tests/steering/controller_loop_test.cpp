// The controller loop without transport: it refuses frames it cannot use, feeds the predictor
// with frames it does not answer, and closes the loop in-process with the patient loop on the
// coarse scenario (liver_700 on both sides): the needle goes through the skin into the liver
// towards the target, every frame answered, no target rejected by the patient's gate; a
// controller started at the end catches up with the one that ran the whole insertion.
#include "common/steering/controller_loop.h"

#include <gtest/gtest.h>

#include "common/core/wire_pose.h"
#include "common/mesh/gmsh_reader.h"
#include "common/scene/lockstep_targets.h"
#include "common/scene/patient_loop.h"
#include "direct_sim/scenario_loader.h"
#include "inverse_sim/scenario_loader.h"

namespace nsim {
namespace {

const std::string kScenario =
    std::string(NSIM_SOURCE_DIR) + "/configs/scenarios/liver_test_coarse.yaml";

struct Loops {
  Loops()
      : direct(LoadDirectScenario(kScenario)),
        inverse(LoadInverseScenario(kScenario)),
        patient(direct.LoopConfig(true), direct.liver_mesh, direct.skin_mesh),
        controller(inverse.loop, ReadGmshMesh(inverse.mesh_path)) {}
  DirectScenario direct;
  InverseScenario inverse;
  PatientLoop patient;
  ControllerLoop controller;
};

// the scenario's loop with a predictor that is ready after 40 frames (a fixed window of 10)
ControllerLoopConfig WithQuickPredictor(ControllerLoopConfig config) {
  config.prediction.pca_window = 40;
  config.prediction.window_max = 20;
  config.prediction.optimize_window = false;
  return config;
}

TEST(ControllerLoopTest, RefusesFramesItCannotUse) {
  Loops loops;
  SensorFrame frame = loops.patient.frame();
  frame.has_robot = false;  // a marker-only stream: nothing to steer
  EXPECT_FALSE(loops.controller.Step(frame).has_value());
  EXPECT_EQ(loops.controller.counts().rejected_frames, 1u);
  EXPECT_NE(loops.controller.counts().last_rejection.find("no robot state"), std::string::npos);
  // the same time again: not a new frame
  frame.has_robot = true;
  EXPECT_FALSE(loops.controller.Step(frame).has_value());
  EXPECT_EQ(loops.controller.counts().rejected_frames, 2u);
  // a wrong marker count
  frame.stamp.sim_time += 0.02;
  frame.p_WM.pop_back();
  EXPECT_FALSE(loops.controller.Step(frame).has_value());
  EXPECT_EQ(loops.controller.counts().rejected_frames, 3u);
  EXPECT_EQ(loops.controller.counts().targets, 0u);
}

// the iiwa's joint law cannot use a frame without the 7 joints (a ROS 2 robot whose joint
// states have not arrived, a Cartesian robot): refused by name, no model built from it
TEST(ControllerLoopTest, AJointLawRefusesFramesWithoutSevenJoints) {
  Loops loops;
  ControllerLoopConfig config = loops.inverse.loop;
  config.control.dof = SteeringDof::kJoint7;
  ControllerLoop joint(config, ReadGmshMesh(loops.inverse.mesh_path));
  SensorFrame frame = loops.patient.frame();  // the Cartesian robot: no joints
  ASSERT_TRUE(frame.q.empty());
  EXPECT_FALSE(joint.Step(frame).has_value());
  EXPECT_EQ(joint.counts().rejected_frames, 1u);
  EXPECT_NE(joint.counts().last_rejection.find("0 joint positions; the iiwa's joint law needs 7"),
            std::string::npos)
      << joint.counts().last_rejection;
  EXPECT_EQ(joint.controller(), nullptr);
  frame.stamp.sim_time += 0.02;
  frame.q = {0, 0, 0, 0, 0, 0};
  EXPECT_FALSE(joint.Step(frame).has_value());
  EXPECT_EQ(joint.counts().rejected_frames, 2u);
  EXPECT_EQ(joint.counts().targets, 0u);
}

TEST(ControllerLoopTest, AnswersEachFrameWithATargetForItsSequenceNumber) {
  Loops loops;
  for (int k = 0; k < 5; ++k) {
    const std::optional<RobotTarget> target = loops.controller.Step(loops.patient.frame());
    ASSERT_TRUE(target.has_value()) << loops.controller.counts().last_rejection;
    EXPECT_EQ(target->answers_seq, loops.patient.frame().stamp.seq);
    EXPECT_EQ(target->stamp.seq, static_cast<uint64_t>(k));
    EXPECT_EQ(target->mode, TargetMode::kCartesian);
    EXPECT_EQ(loops.controller.last_record().answers_seq, loops.patient.frame().stamp.seq);
    loops.patient.Step(*target);
    EXPECT_TRUE(loops.patient.gate().counts().rejected() == 0);
  }
  // a frame only observed feeds the predictor and the score, and is not answered
  loops.controller.Observe(loops.patient.Step());
  EXPECT_EQ(loops.controller.counts().observed, 6u);
  EXPECT_EQ(loops.controller.counts().answered, 5u);
}

// prediction.model_pose: once the markers are predicted over the horizon, the `commanded` model
// puts its needle at the last target sent (where the robot will be), the `measured` one at the
// frame's pose; with a latency of 3 steps the two differ
TEST(ControllerLoopTest, PredictedModelPutsTheNeedleAtTheCommandedPose) {
  Loops loops;
  ControllerLoopConfig config = WithQuickPredictor(loops.inverse.loop);
  config.model_pose = ModelPose::kCommanded;
  ControllerLoop commanded(config, ReadGmshMesh(loops.inverse.mesh_path));
  config.model_pose = ModelPose::kMeasured;
  ControllerLoop measured(config, ReadGmshMesh(loops.inverse.mesh_path));
  const double length = loops.inverse.loop.model.needle.length;
  LockstepTargets delay(3);
  std::optional<RobotTarget> last_commanded;
  int compared = 0;
  double largest_gap = 0.0;
  for (int k = 0; k < 80; ++k) {
    const SensorFrame frame = loops.patient.frame();
    const std::optional<RobotTarget> target = commanded.Step(frame);
    ASSERT_TRUE(target.has_value()) << commanded.counts().last_rejection;
    ASSERT_TRUE(measured.Step(frame).has_value()) << measured.counts().last_rejection;
    const Eigen::Vector3d tip_measured = CalcTipPosition(frame.X_WE, length);
    EXPECT_LT((measured.last_record().model_tip - tip_measured).norm(), 1e-12) << k;
    if (commanded.last_record().predicted && last_commanded && frame.applied_seq != SensorFrame::kNoTarget) {
      const Eigen::Vector3d tip_commanded = CalcTipPosition(last_commanded->X_WE, length);
      EXPECT_LT((commanded.last_record().model_tip - tip_commanded).norm(), 1e-12) << k;
      largest_gap = std::max(largest_gap, (tip_commanded - tip_measured).norm());
      ++compared;
    }
    last_commanded = target;
    delay.Add(*target);
    loops.patient.Step(delay.TakeFor(k));
  }
  EXPECT_GE(compared, 20);
  EXPECT_GT(largest_gap, 1e-4) << "commanded and measured poses never differed";
}

// prediction.model_pose `expected`: the model's needle where the robot's own motion law takes
// it under the commands in flight. In lockstep with a latency of d steps that is exactly the
// patient's needle d frames later (the robot executes those d commands, one a step); the last
// command is not (the robot lags behind it while it accelerates), so the test tells them apart.
// Both robots: the Cartesian one (its limits from the scenario) and the iiwa's joints. `auto`
// resolves to one of the two: the forecast for the iiwa up to kAutoExpectedSteps of measured
// latency, the last command beyond it and for the Cartesian robot (to_forecast says which).
// lose_every > 0: every lose_every-th target is lost on the way (the patient never gets it and
// keeps its command, as under keep-last-1 streams), and every lose_every-th frame, at another
// phase (the controller never sees it, so nothing answers it); the forecast, which skips a
// command once it is overdue and lets the robot keep its command for the step of a frame
// nobody answered, is still exact at every frame whose commands in flight arrived (a loss
// among them is unknowable) and whose previous frame arrived (the robot's velocity over two
// steps is their mean), in particular right after a lost target and over a lost frame; the
// measured latency stays d frames (the loop time grows with each lost frame, the sensor's
// period not).
void CheckModelPose(bool iiwa, ModelPose pose, int d, bool to_forecast, int lose_every = 0) {
  DirectScenario direct = LoadDirectScenario(kScenario);
  if (iiwa) {  // the robot and its gate's joint limits (the loader's, for robot.type: iiwa)
    direct.robot.kind = RobotKind::kIiwa;
    const Iiwa14Config& limits = direct.robot.iiwa;
    direct.safety.joint_lower.assign(limits.position_lower.data(), limits.position_lower.data() + 7);
    direct.safety.joint_upper.assign(limits.position_upper.data(), limits.position_upper.data() + 7);
    direct.safety.joint_velocity.assign(limits.velocity_limit.data(),
                                        limits.velocity_limit.data() + 7);
  }
  const InverseScenario inverse = LoadInverseScenario(kScenario);
  PatientLoop patient(direct.LoopConfig(true), direct.liver_mesh, direct.skin_mesh);
  ControllerLoopConfig config = WithQuickPredictor(inverse.loop);
  config.model_pose = pose;
  if (iiwa) config.control.dof = SteeringDof::kJoint7;
  ControllerLoop controller(config, ReadGmshMesh(inverse.mesh_path));
  const double length = inverse.loop.model.needle.length;
  LockstepTargets delay(d);
  std::vector<Eigen::Vector3d> measured_tips, model_tips, commanded_tips;
  std::vector<bool> forecast, lost, frame_lost;
  std::optional<RobotTarget> last;
  int wrong_latency = 0;
  const int frames = lose_every > 0 ? 120 : 80;  // the losses leave fewer frames to compare
  for (int k = 0; k < frames; ++k) {
    const SensorFrame frame = patient.frame();
    ASSERT_EQ(frame.q.size(), iiwa ? 7u : 0u);
    measured_tips.push_back(CalcTipPosition(frame.X_WE, length));
    frame_lost.push_back(lose_every > 0 && k > 0 && k % lose_every == 0);
    if (frame_lost.back()) {  // nothing answers it; the robot keeps its command
      model_tips.push_back(Eigen::Vector3d::Constant(NAN));
      forecast.push_back(false);
      commanded_tips.push_back(measured_tips.back());
      lost.push_back(false);
      patient.Step(delay.TakeFor(k));
      continue;
    }
    const std::optional<RobotTarget> target = controller.Step(frame);
    ASSERT_TRUE(target.has_value()) << controller.counts().last_rejection;
    ASSERT_EQ(target->mode, iiwa ? TargetMode::kJoint : TargetMode::kCartesian);
    model_tips.push_back(controller.last_record().model_tip);
    // a forecast needs a measured latency (the frame period) and two observed frames
    forecast.push_back(controller.last_record().predicted && k > 1 &&
                       frame.applied_seq != SensorFrame::kNoTarget &&
                       controller.last_record().latency_steps == d);
    wrong_latency += controller.last_record().predicted && k > 10 &&
                     controller.last_record().latency_steps != d;
    commanded_tips.push_back(last ? CalcTipPosition(last->X_WE, length) : measured_tips.back());
    last = target;
    lost.push_back(lose_every > 0 && k % lose_every == lose_every / 2);
    if (!lost.back()) delay.Add(*target);
    patient.Step(delay.TakeFor(k));
  }
  int compared = 0, after_loss = 0, after_lost_frame = 0;
  double largest_lag = 0.0;
  for (size_t k = 0; k + d < model_tips.size(); ++k) {
    if (!forecast[k]) continue;
    // over the frames k - d .. k - 1: a command in flight at frame k lost, and a step of the
    // forecast that kept the command (a lost frame)
    bool in_flight_lost = false, frame_in_window = false;
    for (size_t j = k >= static_cast<size_t>(d) ? k - d : 0; j < k; ++j) {
      in_flight_lost = in_flight_lost || lost[j];
      frame_in_window = frame_in_window || frame_lost[j];
    }
    // right after a lost frame the robot's velocity is the mean over two steps: not exact
    if (in_flight_lost || (k > 0 && frame_lost[k - 1])) continue;
    after_loss += k >= static_cast<size_t>(d) + 1 && lost[k - d - 1] ? 1 : 0;
    after_lost_frame += frame_in_window ? 1 : 0;
    if (to_forecast)
      EXPECT_LT((model_tips[k] - measured_tips[k + d]).norm(), 1e-9) << k;
    else
      EXPECT_LT((model_tips[k] - commanded_tips[k]).norm(), 1e-12) << k;
    largest_lag = std::max(largest_lag, (commanded_tips[k] - measured_tips[k + d]).norm());
    ++compared;
  }
  std::printf("%s, %s, %d steps: %d forecasts, the last command up to %.3g mm from where the "
              "needle went\n", iiwa ? "iiwa" : "Cartesian robot", ModelPoseName(pose), d, compared,
              largest_lag * 1e3);
  EXPECT_GE(compared, 20);
  EXPECT_GT(largest_lag, 1e-5) << "the robot kept up with every command: nothing forecast";
  EXPECT_EQ(wrong_latency, 0) << "the measured latency left " << d << " frames";
  if (lose_every > 0) {
    EXPECT_GE(after_loss, 3) << "no forecast right after a lost target";
    if (d > 1) {
      EXPECT_GE(after_lost_frame, 3) << "no forecast over a lost frame";
    }
    EXPECT_GE(controller.counts().unapplied_targets, 3u);
  }
}

TEST(ControllerLoopTest, ExpectedModelPoseIsWhereTheCartesianRobotWillBe) {
  CheckModelPose(false, ModelPose::kExpected, 3, true);
}

TEST(ControllerLoopTest, ExpectedModelPoseIsWhereTheIiwaWillBe) {
  CheckModelPose(true, ModelPose::kExpected, 3, true);
}

TEST(ControllerLoopTest, ExpectedModelPoseSkipsTheTargetsTheRobotNeverGot) {
  CheckModelPose(true, ModelPose::kExpected, 1, true, 7);
  CheckModelPose(true, ModelPose::kExpected, 3, true, 9);
  CheckModelPose(false, ModelPose::kExpected, 2, true, 8);
}

// `auto`: the iiwa's forecast at 1 and kAutoExpectedSteps steps, its last command beyond; the
// Cartesian robot's last command at any latency
TEST(ControllerLoopTest, AutoModelPoseIsTheIiwasForecastAtShortLatencies) {
  CheckModelPose(true, ModelPose::kAuto, 1, true);
  CheckModelPose(true, ModelPose::kAuto, kAutoExpectedSteps, true);
  CheckModelPose(true, ModelPose::kAuto, kAutoExpectedSteps + 1, false);
  CheckModelPose(false, ModelPose::kAuto, 1, false);
}

// prediction.preparation (thesis fig. 4.1): the robot is held at its first pose, the model
// following the markers, until the predictor's buffer is full; then the law steers. Without
// it the first target already moves the needle.
TEST(ControllerLoopTest, PreparationHoldsTheRobotUntilThePredictorIsReady) {
  Loops loops;
  ControllerLoopConfig config = WithQuickPredictor(loops.inverse.loop);
  config.preparation = Preparation::kBuffer;
  ControllerLoop prepared(config, ReadGmshMesh(loops.inverse.mesh_path));
  config.preparation = Preparation::kNone;
  ControllerLoop unprepared(config, ReadGmshMesh(loops.inverse.mesh_path));
  const Eigen::Isometry3d X_WE0 = loops.patient.frame().X_WE;
  const std::optional<RobotTarget> first = unprepared.Step(loops.patient.frame());
  ASSERT_TRUE(first.has_value()) << unprepared.counts().last_rejection;
  EXPECT_GT((first->X_WE.translation() - X_WE0.translation()).norm(), 1e-4);
  LockstepTargets delay(1);
  int held = 0;
  double moved_after = 0.0;
  for (int k = 0; k < 60; ++k) {
    const SensorFrame frame = loops.patient.frame();
    const std::optional<RobotTarget> target = prepared.Step(frame);
    ASSERT_TRUE(target.has_value()) << k << ": " << prepared.counts().last_rejection;
    const bool ready = prepared.predictor()->ready();
    EXPECT_EQ(prepared.last_record().preparing, !ready) << k;
    if (!ready) {
      ++held;
      EXPECT_TRUE(target->X_WE.isApprox(X_WE0, 0.0)) << k;  // the hold pose, to the bit
      EXPECT_LT((frame.X_WE.translation() - X_WE0.translation()).norm(), 1e-12) << k;
      EXPECT_EQ(prepared.last_record().timings.jacobian, 0.0) << k;  // a held step has none
    } else {
      EXPECT_GT(prepared.last_record().timings.jacobian, 0.0) << k;
      moved_after = std::max(moved_after, (target->X_WE.translation() - X_WE0.translation()).norm());
    }
    EXPECT_EQ(target->answers_seq, frame.stamp.seq);
    delay.Add(*target);
    loops.patient.Step(delay.TakeFor(k));
    ASSERT_TRUE(loops.patient.healthy()) << loops.patient.fault();
  }
  EXPECT_EQ(held, 39);  // the 40th frame fills the buffer: it is answered by the law
  EXPECT_EQ(prepared.counts().prepared, 39u);
  EXPECT_GT(moved_after, 1e-3);  // the insertion started
  EXPECT_EQ(loops.patient.gate().counts().rejected(), 0u);
}

// prediction.preparation: exhale: held past the buffer's fill until the breathing enters its
// exhale rest (ExhaleGate, tested against a closed form in exhale_gate_test) within a breathing
// period (4 s), before the fallback of one more buffer's length; then the law steers
TEST(ControllerLoopTest, AnExhaleGatedStartWaitsForTheExhaleRest) {
  Loops loops;
  ControllerLoopConfig config = loops.inverse.loop;
  config.prediction.pca_window = 250;  // 5 s: more than a breathing period
  config.prediction.window_max = 20;
  config.prediction.optimize_window = false;
  config.preparation = Preparation::kExhale;
  ControllerLoop gated(config, ReadGmshMesh(loops.inverse.mesh_path));
  const Eigen::Isometry3d X_WE0 = loops.patient.frame().X_WE;
  LockstepTargets delay(1);
  int held = 0;
  for (int k = 0; k < 600 && (k == 0 || gated.last_record().preparing); ++k) {
    const std::optional<RobotTarget> target = gated.Step(loops.patient.frame());
    ASSERT_TRUE(target.has_value()) << k << ": " << gated.counts().last_rejection;
    if (gated.last_record().preparing) {
      EXPECT_TRUE(target->X_WE.isApprox(X_WE0, 0.0)) << k;
      ++held;
    }
    delay.Add(*target);
    loops.patient.Step(delay.TakeFor(k));
  }
  std::printf("exhale-gated start: held %d frames (%.2f s)\n", held, held * 0.02);
  EXPECT_FALSE(gated.last_record().preparing);
  EXPECT_GE(held, 249);           // the buffer's fill first
  EXPECT_LE(held, 249 + 200);     // then the next exhale rest, within a period
  EXPECT_EQ(gated.counts().prepared, static_cast<uint64_t>(held));
}

// prediction.shrink: a loop that shrinks its predicted displacements and one that does not,
// fed the same frames (the patient driven by the second): the predictor's own predictions are
// the same in both (its score equal to the bit), the shrinking one registers to others (its
// score differs) and records the mean factor, in [0, 1], below 1 once a prediction missed
TEST(ControllerLoopTest, ShrinkScalesThePredictedDisplacements) {
  Loops loops;
  ControllerLoopConfig config = WithQuickPredictor(loops.inverse.loop);
  config.prediction_shrink = true;
  ControllerLoop shrinking(config, ReadGmshMesh(loops.inverse.mesh_path));
  config.prediction_shrink = false;
  ControllerLoop plain(config, ReadGmshMesh(loops.inverse.mesh_path));
  LockstepTargets delay(3);
  double lowest = 1.0;
  for (int k = 0; k < 120; ++k) {
    const SensorFrame frame = loops.patient.frame();
    const std::optional<RobotTarget> target = plain.Step(frame);
    ASSERT_TRUE(target.has_value()) << plain.counts().last_rejection;
    ASSERT_TRUE(shrinking.Step(frame).has_value()) << shrinking.counts().last_rejection;
    const double alpha = shrinking.last_record().shrinkage;
    EXPECT_GE(alpha, 0.0) << k;
    EXPECT_LE(alpha, 1.0) << k;
    EXPECT_EQ(plain.last_record().shrinkage, 1.0) << k;
    if (!shrinking.last_record().predicted) {
      EXPECT_EQ(alpha, 1.0) << k;
    }
    lowest = std::min(lowest, alpha);
    delay.Add(*target);
    loops.patient.Step(delay.TakeFor(k));
  }
  ASSERT_GT(plain.score().scored(), 60u);
  const auto own = shrinking.predictor_score().NrmsPercent(), unshrunk = plain.score().NrmsPercent(),
             used = shrinking.score().NrmsPercent();
  ASSERT_EQ(own.size(), unshrunk.size());
  bool differs = false;
  for (size_t m = 0; m < own.size(); ++m) {
    ASSERT_TRUE(own[m] && unshrunk[m] && used[m]);
    EXPECT_EQ(*own[m], *unshrunk[m]) << "marker " << m;
    EXPECT_EQ(*plain.predictor_score().NrmsPercent()[m], *unshrunk[m]) << "marker " << m;
    differs = differs || *used[m] != *own[m];
  }
  EXPECT_TRUE(differs);
  EXPECT_LT(lowest, 1.0);
}

// the closed loop in-process, lockstep with a latency of 1 step
TEST(ControllerLoopTest, ClosedLoopInProcessInsertsTowardsTheTarget) {
  Loops loops;
  LockstepTargets delay(1);
  const double start_distance = loops.patient.record().distance;
  const int steps = 300;  // 6 s: through the skin (at ~1.5 s) into the liver
  for (int k = 0; k < steps; ++k) {
    std::optional<RobotTarget> target = loops.controller.Step(ThroughWire(loops.patient.frame()));
    ASSERT_TRUE(target.has_value()) << "step " << k << ": " << loops.controller.counts().last_rejection;
    delay.Add(ThroughWire(*target));
    ASSERT_TRUE(delay.Ready(k));
    loops.patient.Step(delay.TakeFor(k));
    ASSERT_TRUE(loops.patient.healthy()) << loops.patient.fault();
  }
  const PatientRecord& r = loops.patient.record();
  EXPECT_TRUE(r.skin.punctured);
  EXPECT_TRUE(r.liver.punctured);
  EXPECT_LT(r.distance, 0.5 * start_distance);
  EXPECT_EQ(loops.patient.gate().counts().accepted, static_cast<uint64_t>(steps - 1));
  EXPECT_EQ(loops.patient.gate().counts().rejected(), 0u);
  EXPECT_EQ(loops.controller.counts().answered, static_cast<uint64_t>(steps));
  EXPECT_EQ(loops.controller.counts().rejected_frames, 0u);
  EXPECT_GT(loops.controller.loop_period().count, 0u);
  EXPECT_EQ(loops.controller.phase(), 2);  // the model too knows the needle is in the liver
  EXPECT_FALSE(loops.controller.catch_up().done);  // it started with the needle outside
  EXPECT_EQ(loops.controller.first_answered_seq(), 0);

  // A controller started now (the tip at the target, 65 mm past the path's start) catches up
  // from this frame alone: its model punctured the liver and has the trajectory points, the
  // path index and the phase of the one that followed the whole insertion; the liver around
  // the needle is within 1.1 mm of it (measured), the target within 0.1 mm.
  // (with the preparation phase on: a controller that catches up does not hold the needle)
  ControllerLoopConfig config = loops.inverse.loop;
  config.preparation = Preparation::kExhale;
  ControllerLoop restarted(config, ReadGmshMesh(loops.inverse.mesh_path));
  const SensorFrame frame = ThroughWire(loops.patient.frame());
  ASSERT_TRUE(loops.controller.Step(frame).has_value());
  ASSERT_TRUE(restarted.Step(frame).has_value()) << restarted.counts().last_rejection;
  const CatchUpReport& c = restarted.catch_up();
  EXPECT_TRUE(c.done);
  EXPECT_EQ(restarted.first_answered_seq(), steps);
  EXPECT_FALSE(restarted.last_record().preparing);
  EXPECT_EQ(restarted.counts().prepared, 0u);
  EXPECT_EQ(c.liver_phase, TissuePhase::kInside);
  EXPECT_EQ(restarted.phase(), loops.controller.phase());
  const ControllerRecord &a = loops.controller.last_record(), &b = restarted.last_record();
  const SteeringSimulation &ma = loops.controller.controller()->simulation(),
                           &mb = restarted.controller()->simulation();
  Eigen::Vector3d entry_a, entry_b;
  ASSERT_TRUE(ma.CalcLiverEntryPoint(&entry_a));
  ASSERT_TRUE(mb.CalcLiverEntryPoint(&entry_b));
  const double target = (ma.CalcPathPositions().back() - mb.CalcPathPositions().back()).norm();
  const double nodes = (ma.liver_positions() - mb.liver_positions()).colwise().norm().maxCoeff();
  std::printf("catch-up: %.1f mm deep, moved %.2f mm to the measured tip, %d model steps, %.2f s; "
              "path index %d vs %d; points %zu vs %zu; apart: entry point %.3f mm, target %.3f "
              "mm, nodes %.3f mm\n",
              1e3 * c.depth, 1e3 * c.aligned, c.steps, c.wall_time, a.path_index, b.path_index,
              ma.liver_coupling().points.size(), mb.liver_coupling().points.size(),
              1e3 * (entry_a - entry_b).norm(), 1e3 * target, 1e3 * nodes);
  EXPECT_EQ(b.path_index, a.path_index);
  EXPECT_EQ(mb.liver_coupling().points.size(), ma.liver_coupling().points.size());
  EXPECT_EQ(b.model_tip, a.model_tip);  // the same measured pose
  EXPECT_LT((entry_a - entry_b).norm(), 0.5e-3);
  EXPECT_LT(target, 0.2e-3);
  EXPECT_LT(nodes, 1.5e-3);
}

}  // namespace
}  // namespace nsim
