#include "messages/convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/core/wire_pose.h"

namespace nsim::transport {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d SomePose() {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  X.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  return X;
}

SensorFrame SomeFrame() {
  SensorFrame in;
  in.stamp = {42, 1.25, 123456789};
  in.p_WM = {{1, 2, 3}, {-4, 5e-9, 6}};
  in.X_WE = SomePose();
  in.q = {0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7};
  in.bevel_angle = 0.25;
  in.entry_punctured = true;
  in.p_WP = {0.01, 0.02, 0.03};
  in.n_W = {0, 1, 0};
  return in;
}

TEST(Convert, SensorFrameRoundTrip) {
  const SensorFrame in = SomeFrame();
  nsim_msgs_SensorFrame msg{};
  ConvertScratch scratch;
  ToMessage(in, msg, scratch);
  SensorFrame out;
  EXPECT_EQ(FromMessage(msg, out), "");
  EXPECT_EQ(out.stamp.seq, 42u);
  EXPECT_EQ(out.stamp.sim_time, 1.25);
  EXPECT_EQ(out.stamp.wall_time_ns, 123456789);
  ASSERT_EQ(out.p_WM.size(), 2u);
  EXPECT_EQ(out.p_WM[1], in.p_WM[1]);
  EXPECT_TRUE(out.has_robot);
  EXPECT_TRUE(out.X_WE.isApprox(in.X_WE, 1e-14));
  EXPECT_EQ(out.q, in.q);
  EXPECT_EQ(out.bevel_angle, 0.25);
  EXPECT_TRUE(out.entry_punctured);
  EXPECT_EQ(out.p_WP, in.p_WP);
  EXPECT_EQ(out.n_W, in.n_W);
}

// the in-process closed loop relies on this: what a receiver gets is ThroughWire, bitwise
TEST(Convert, ThroughWireIsExactlyWhatTheReceiverGets) {
  for (int i = 0; i < 50; ++i) {
    SensorFrame in = SomeFrame();
    in.X_WE.linear() = Eigen::AngleAxisd(0.05 * i - 1.2, Eigen::Vector3d(1, -2, 0.5 + 0.1 * i).normalized())
                           .toRotationMatrix();
    nsim_msgs_SensorFrame msg{};
    ConvertScratch scratch;
    ToMessage(in, msg, scratch);
    SensorFrame out;
    ASSERT_EQ(FromMessage(msg, out), "");
    EXPECT_EQ(out.X_WE.matrix(), ThroughWire(in).X_WE.matrix()) << i;

    RobotTarget target;
    target.X_WE = in.X_WE;
    nsim_msgs_RobotTarget target_msg{};
    ToMessage(target, target_msg, scratch);
    RobotTarget target_out;
    ASSERT_EQ(FromMessage(target_msg, target_out), "");
    EXPECT_EQ(target_out.X_WE.matrix(), ThroughWire(target).X_WE.matrix()) << i;
  }
}

TEST(Convert, AMarkerOnlyFrameCarriesNoRobot) {
  SensorFrame in = SomeFrame();
  in.has_robot = false;
  nsim_msgs_SensorFrame msg{};
  ConvertScratch scratch;
  ToMessage(in, msg, scratch);
  msg.X_WE.qw = kNaN;  // ignored: the robot fields are unset in a marker-only stream
  SensorFrame out;
  ASSERT_EQ(FromMessage(msg, out), "");
  EXPECT_FALSE(out.has_robot);
  EXPECT_TRUE(out.q.empty());
  EXPECT_FALSE(out.entry_punctured);
  EXPECT_EQ(out.p_WM, in.p_WM);
}

TEST(Convert, RobotTargetRoundTripKeepsPoseAndJoints) {
  RobotTarget in;
  in.stamp.seq = 7;
  in.answers_seq = 5;
  in.mode = TargetMode::kJoint;
  in.X_WE = SomePose();
  in.q = {0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7};
  in.bevel_angle = 1.5;
  nsim_msgs_RobotTarget msg{};
  ConvertScratch scratch;
  ToMessage(in, msg, scratch);
  RobotTarget out;
  ASSERT_EQ(FromMessage(msg, out), "");
  EXPECT_EQ(out.answers_seq, 5u);
  EXPECT_EQ(out.mode, TargetMode::kJoint);
  EXPECT_TRUE(out.X_WE.isApprox(in.X_WE, 1e-14));
  EXPECT_EQ(out.q, in.q);
  EXPECT_EQ(out.bevel_angle, 1.5);
}

TEST(Convert, StatusRoundTrip) {
  ConvertScratch scratch;
  SimStatus st;
  st.sender = "direct_sim";
  st.state = RunState::kFinished;
  st.last_seq = 99;
  st.message = std::string(300, 'x');  // longer than the bounded string: truncated, not overflowed
  st.scenario_hash = 0x0123456789abcdefull;
  nsim_msgs_SimStatus st_msg{};
  ToMessage(st, st_msg, scratch);
  SimStatus st_out;
  ASSERT_EQ(FromMessage(st_msg, st_out), "");
  EXPECT_EQ(st_out.sender, "direct_sim");
  EXPECT_EQ(st_out.state, RunState::kFinished);
  EXPECT_EQ(st_out.last_seq, 99u);
  EXPECT_EQ(st_out.message.size(), 256u);
  EXPECT_EQ(st_out.scenario_hash, 0x0123456789abcdefull);
}

TEST(Convert, InvalidMessagesAreNamed) {
  ConvertScratch scratch;
  SensorFrame mf = SomeFrame();
  mf.p_WM = {{0, 0, 0}, {0, kNaN, 0}};
  nsim_msgs_SensorFrame mf_msg{};
  ToMessage(mf, mf_msg, scratch);
  SensorFrame mf_out;
  EXPECT_EQ(FromMessage(mf_msg, mf_out), "p_WM is not finite (marker 1)");
  mf.p_WM = {{0, 0, 0}};
  mf.n_W = {0, 2, 0};
  ToMessage(mf, mf_msg, scratch);
  EXPECT_EQ(FromMessage(mf_msg, mf_out), "n_W norm is 2, expected 1");
  mf.n_W = {0, 1, 0};
  mf.bevel_angle = kNaN;
  ToMessage(mf, mf_msg, scratch);
  EXPECT_EQ(FromMessage(mf_msg, mf_out), "bevel_angle is not finite");

  RobotTarget rt;
  nsim_msgs_RobotTarget rt_msg{};
  ToMessage(rt, rt_msg, scratch);
  rt_msg.X_WE.qw = 2.0;  // not a unit quaternion
  RobotTarget rt_out;
  EXPECT_NE(FromMessage(rt_msg, rt_out).find("X_WE quaternion norm"), std::string::npos);
  ToMessage(rt, rt_msg, scratch);
  rt_msg.mode = 9;
  EXPECT_NE(FromMessage(rt_msg, rt_out).find("mode must be 0"), std::string::npos);
  ToMessage(rt, rt_msg, scratch);
  rt_msg.stamp.sim_time = kNaN;
  EXPECT_EQ(FromMessage(rt_msg, rt_out), "stamp.sim_time is not finite");
}

}  // namespace
}  // namespace nsim::transport
