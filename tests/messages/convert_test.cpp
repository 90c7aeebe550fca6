#include "messages/convert.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace nsim::transport {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d SomePose() {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  X.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  return X;
}

TEST(Convert, MarkerFrameRoundTrip) {
  MarkerFrame in;
  in.stamp = {42, 1.25, 123456789};
  in.p_WM = {{1, 2, 3}, {-4, 5e-9, 6}};
  nsim_msgs_MarkerFrame msg{};
  ConvertScratch scratch;
  ToMessage(in, msg, scratch);
  MarkerFrame out;
  EXPECT_EQ(FromMessage(msg, out), "");
  EXPECT_EQ(out.stamp.seq, 42u);
  EXPECT_EQ(out.stamp.sim_time, 1.25);
  EXPECT_EQ(out.stamp.wall_time_ns, 123456789);
  ASSERT_EQ(out.p_WM.size(), 2u);
  EXPECT_EQ(out.p_WM[1], in.p_WM[1]);
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

TEST(Convert, RobotStateEntryPointAndStatusRoundTrip) {
  RobotState rs;
  rs.X_WE = SomePose();
  rs.q = {1, 2};
  nsim_msgs_RobotState rs_msg{};
  ConvertScratch scratch;
  ToMessage(rs, rs_msg, scratch);
  RobotState rs_out;
  ASSERT_EQ(FromMessage(rs_msg, rs_out), "");
  EXPECT_TRUE(rs_out.X_WE.isApprox(rs.X_WE, 1e-14));
  EXPECT_EQ(rs_out.q, rs.q);

  EntryPoint ep;
  ep.punctured = true;
  ep.p_WP = {0.01, 0.02, 0.03};
  ep.n_W = {0, 1, 0};
  nsim_msgs_EntryPoint ep_msg{};
  ToMessage(ep, ep_msg, scratch);
  EntryPoint ep_out;
  ASSERT_EQ(FromMessage(ep_msg, ep_out), "");
  EXPECT_TRUE(ep_out.punctured);
  EXPECT_EQ(ep_out.p_WP, ep.p_WP);

  SimStatus st;
  st.sender = "direct_sim";
  st.state = RunState::kFinished;
  st.last_seq = 99;
  st.message = std::string(300, 'x');  // longer than the bounded string: truncated, not overflowed
  nsim_msgs_SimStatus st_msg{};
  ToMessage(st, st_msg, scratch);
  SimStatus st_out;
  ASSERT_EQ(FromMessage(st_msg, st_out), "");
  EXPECT_EQ(st_out.sender, "direct_sim");
  EXPECT_EQ(st_out.state, RunState::kFinished);
  EXPECT_EQ(st_out.last_seq, 99u);
  EXPECT_EQ(st_out.message.size(), 256u);
}

TEST(Convert, InvalidMessagesAreNamed) {
  ConvertScratch scratch;
  MarkerFrame mf;
  mf.p_WM = {{0, 0, 0}, {0, kNaN, 0}};
  nsim_msgs_MarkerFrame mf_msg{};
  ToMessage(mf, mf_msg, scratch);
  MarkerFrame mf_out;
  EXPECT_EQ(FromMessage(mf_msg, mf_out), "p_WM is not finite (marker 1)");

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
