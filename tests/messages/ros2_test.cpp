// In-process checks of the ROS 2 side over loopback: the time conversion, the JointState
// names, and a Ros2Mirror's messages assembled back into SensorFrames by a Ros2Input (what a
// frame needs to be complete, the entry point, frames of another frame_id dropped). ROS 2 has
// no partition: this test has a domain of its own (61).
#include "messages/ros2.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/core/clock.h"
#include "common/core/error.h"
#include "messages/ros2_convert.h"

namespace nsim::transport {
namespace {

Ros2Config LoopbackConfig() {
  Ros2Config c;
  c.config_file = NSIM_SOURCE_DIR "/configs/dds/local.xml";
  c.domain_id = 61;
  return c;
}

// takes from `input` until `count` frames have come or `timeout_s` has passed
std::vector<SensorFrame> TakeUntil(Ros2Input& input, size_t count, double timeout_s) {
  std::vector<SensorFrame> out;
  const double end = MonotonicSeconds() + timeout_s;
  while (out.size() < count && MonotonicSeconds() < end) {
    input.Wait(0.05);
    input.Take(out);
  }
  return out;
}

SensorFrame RobotFrame(double t) {
  SensorFrame f;
  f.stamp.sim_time = t;
  f.p_WM = {{0.01, -0.02, 0.125}, {1.0 / 3.0, 2e-7, -5.5}};
  f.X_WE = Eigen::Translation3d(0.1, 0.2, 0.3) *
           Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  f.q = {0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7};
  return f;
}

TEST(Ros2, TimeIsSecondsAndNanoseconds) {
  const auto t = ToRos2Time(12.25);
  EXPECT_EQ(t.sec, 12);
  EXPECT_EQ(t.nanosec, 250000000u);
  EXPECT_EQ(FromRos2Time(t), 12.25);
  const auto up = ToRos2Time(0.9999999999);  // rounds to the next second
  EXPECT_EQ(up.sec, 1);
  EXPECT_EQ(up.nanosec, 0u);
  for (double s : {0.0, 0.02, 1.0 / 3.0, 19.98, 1234.56789})
    EXPECT_NEAR(FromRos2Time(ToRos2Time(s)), s, 0.6e-9) << s;
}

TEST(Ros2, JointStateIsReadByNameOrInOrder) {
  sensor_msgs_msg_dds__JointState_ m{};
  Ros2Scratch scratch;
  const std::string world = "world";
  ToRos2Joints(0.5, {1, 2, 3, 4, 5, 6, 7}, world, m, scratch);
  std::vector<double> q;
  EXPECT_EQ(FromRos2Joints(m, &q), "");
  EXPECT_EQ(q, (std::vector<double>{1, 2, 3, 4, 5, 6, 7}));
  // a driver's order and an extra joint
  std::vector<char*> names;
  std::vector<std::string> text = {"gripper", "a7", "a6", "a5", "a4", "a3", "a2", "a1"};
  for (auto& s : text) names.push_back(s.data());
  std::vector<double> positions = {9, 7, 6, 5, 4, 3, 2, 1};
  m.name = {8, 8, names.data(), false};
  m.position = {8, 8, positions.data(), false};
  EXPECT_EQ(FromRos2Joints(m, &q), "");
  EXPECT_EQ(q, (std::vector<double>{1, 2, 3, 4, 5, 6, 7}));
  text[1] = "joint7";
  names[1] = text[1].data();
  EXPECT_NE(FromRos2Joints(m, &q).find("no joint named a7"), std::string::npos);
  m.name = {0, 0, nullptr, false};  // unnamed: in order
  EXPECT_EQ(FromRos2Joints(m, &q), "");
  EXPECT_EQ(q, positions);
}

TEST(Ros2, DomainComesFromTheCommandLineOrRosDomainId) {
  TransportConfig t;
  t.domain_id = 5;
  setenv("ROS_DOMAIN_ID", "12", 1);
  EXPECT_EQ(Ros2ConfigFor(t, true).domain_id, 5);
  EXPECT_EQ(Ros2ConfigFor(t, false).domain_id, 12);
  setenv("ROS_DOMAIN_ID", "12x", 1);
  EXPECT_THROW(Ros2ConfigFor(t, false), InputError);
  unsetenv("ROS_DOMAIN_ID");
  EXPECT_EQ(Ros2ConfigFor(t, false).domain_id, 0);
}

TEST(Ros2, MirroredFramesAreAssembledBack) {
  Ros2Mirror mirror(LoopbackConfig(), {true, false, false, false});
  Ros2Input input(LoopbackConfig(), Eigen::Vector3d(0, 0, 2));
  ASSERT_TRUE(mirror.WaitForSubscribers(1, {ros2_topic::kMarkers}, 10.0).empty());
  // markers alone do not make a frame
  SensorFrame markers_only;
  markers_only.stamp.sim_time = 0.01;
  markers_only.p_WM = {{1, 2, 3}};
  markers_only.has_robot = false;
  mirror.PublishFrame(markers_only);
  const double end = MonotonicSeconds() + 10.0;
  std::vector<SensorFrame> got;
  while (input.counts().incomplete == 0 && MonotonicSeconds() < end) {
    input.Wait(0.05);
    input.Take(got);
  }
  EXPECT_EQ(input.counts().incomplete, 1u);
  EXPECT_TRUE(got.empty());

  SensorFrame f = RobotFrame(0.02);
  mirror.PublishFrame(f);
  got = TakeUntil(input, 1, 10.0);
  ASSERT_EQ(got.size(), 1u);
  const SensorFrame& g = got[0];
  EXPECT_EQ(g.stamp.seq, 0u);
  EXPECT_NEAR(g.stamp.sim_time, 0.02, 1e-9);
  ASSERT_EQ(g.p_WM.size(), 2u);
  EXPECT_EQ(g.p_WM[0], f.p_WM[0]);  // bit for bit
  EXPECT_EQ(g.p_WM[1], f.p_WM[1]);
  EXPECT_TRUE(g.has_robot);
  EXPECT_TRUE(g.X_WE.isApprox(f.X_WE, 1e-14));
  EXPECT_EQ(g.q, f.q);
  EXPECT_FALSE(g.entry_punctured);
  EXPECT_EQ(g.applied_seq, SensorFrame::kNoTarget);

  // the entry point once punctured, with the configured normal
  f = RobotFrame(0.04);
  f.entry_punctured = true;
  f.p_WP = {0.05, 0.06, 0.07};
  mirror.PublishFrame(f);
  got = TakeUntil(input, 1, 10.0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].stamp.seq, 1u);
  EXPECT_TRUE(got[0].entry_punctured);
  EXPECT_EQ(got[0].p_WP, f.p_WP);
  EXPECT_TRUE(got[0].n_W.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_EQ(input.counts().invalid, 0u);
  EXPECT_EQ(input.counts().frames, 2u);
  EXPECT_TRUE(mirror.WaitForAcks(5.0));
}

// a joint-space controller (the iiwa's joint law) needs the joints: a frame without joint
// states is incomplete, a JointState without the seventh joint is invalid and named
TEST(Ros2, AJointControllerWaitsForSevenJoints) {
  Ros2Mirror mirror(LoopbackConfig(), {true, false, false, false});
  Ros2Input input(LoopbackConfig(), Eigen::Vector3d::UnitZ(), 7);
  ASSERT_EQ(mirror.WaitForSubscribers(
                1, {ros2_topic::kMarkers, ros2_topic::kRobotPose, ros2_topic::kJointStates}, 10.0),
            "");
  SensorFrame no_joints = RobotFrame(0.02);
  no_joints.q.clear();
  mirror.PublishFrame(no_joints);
  std::vector<SensorFrame> got;
  double end = MonotonicSeconds() + 10.0;
  while ((input.counts().incomplete < 1 || input.counts().robot_poses < 1) &&
         MonotonicSeconds() < end) {
    input.Wait(0.05);
    input.Take(got);
  }
  EXPECT_EQ(input.counts().incomplete, 1u);
  EXPECT_EQ(input.counts().robot_poses, 1u);
  EXPECT_TRUE(got.empty());

  SensorFrame six = RobotFrame(0.04);
  six.q.pop_back();
  mirror.PublishFrame(six);
  end = MonotonicSeconds() + 10.0;
  while ((input.counts().invalid < 1 || input.counts().incomplete < 2) &&
         MonotonicSeconds() < end) {
    input.Wait(0.05);
    input.Take(got);
  }
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(input.counts().invalid, 1u);
  EXPECT_NE(input.counts().last_invalid.find("no joint named a7"), std::string::npos)
      << input.counts().last_invalid;

  const SensorFrame full = RobotFrame(0.06);
  mirror.PublishFrame(full);
  got = TakeUntil(input, 1, 10.0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].q, full.q);
  EXPECT_NEAR(got[0].stamp.sim_time, 0.06, 1e-9);
}

TEST(Ros2, AnotherFrameIdIsDropped) {
  Ros2Config other = LoopbackConfig();
  other.frame_id = "camera";
  Ros2Mirror mirror(other, {true, false, false, false});
  Ros2Input input(LoopbackConfig(), Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(mirror.WaitForSubscribers(1, {ros2_topic::kMarkers}, 10.0).empty());
  mirror.PublishFrame(RobotFrame(0.5));
  const double end = MonotonicSeconds() + 10.0;
  std::vector<SensorFrame> got;
  while (input.counts().invalid < 2 && MonotonicSeconds() < end) {
    input.Wait(0.05);
    input.Take(got);
  }
  EXPECT_TRUE(got.empty());
  EXPECT_GE(input.counts().invalid, 2u);  // the markers and the robot pose
  EXPECT_NE(input.counts().last_invalid.find("'camera', expected 'world'"), std::string::npos);
}

TEST(Ros2, TargetsArePosesAndJointCommands) {
  Ros2Mirror mirror(LoopbackConfig(), {false, true, true, false});
  // what a subscriber gets is checked by the Fast DDS interoperability test; here the
  // publishing and the conversion of the pose
  RobotTarget target;
  target.stamp.sim_time = 1.5;
  target.mode = TargetMode::kJoint;
  target.q = {0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  target.X_WE = Eigen::Translation3d(0, 0, 1) * Eigen::Isometry3d::Identity();
  EXPECT_NO_THROW(mirror.PublishTarget(target));
  // no markers writer on a target mirror: none to wait for, the wait names the topic
  EXPECT_EQ(mirror.subscribers(ros2_topic::kMarkers), 0);
  EXPECT_EQ(mirror.WaitForSubscribers(1, {ros2_topic::kMarkers}, 0.05), ros2_topic::kMarkers);
  EXPECT_EQ(mirror.WaitForSubscribers(0, {ros2_topic::kMarkers}, 0.0), "");
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  ToRos2Pose(target.stamp.sim_time, target.X_WE, "world", pose);
  EXPECT_EQ(pose.pose.orientation.w, 1.0);
  EXPECT_EQ(pose.pose.position.z, 1.0);
  EXPECT_EQ(pose.header.stamp.sec, 1);
  EXPECT_EQ(pose.header.stamp.nanosec, 500000000u);
}

}  // namespace
}  // namespace nsim::transport
