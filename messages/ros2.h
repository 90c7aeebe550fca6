#pragma once
// The ROS 2 side of the simulator: standard ROS 2 message types (messages/ros2/*.idl) on ROS 2
// topic names, after the ROS 2 DDS mapping (ROS topic /nsim/markers = DDS topic
// rt/nsim/markers; ROS type geometry_msgs/msg/PoseArray = DDS type
// geometry_msgs::msg::dds_::PoseArray_), on the ROS 2 domain without a partition, with the ROS 2
// default QoS (reliable, volatile, keep last 10). A ROS 2 node (RViz, ros2 topic echo, a robot
// driver, a tracker) talks to it without any bridge.
//
// Ros2Mirror publishes the internal samples (common/core/samples.h); Ros2Input assembles
// SensorFrames from what others publish. Like transport.h this header does not include Cyclone;
// the conversion is in messages/ros2_convert.cpp.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/core/samples.h"
#include "messages/transport.h"

namespace nsim::transport {

/// The ROS 2 topic names (the DDS topic is "rt" followed by the name).
namespace ros2_topic {
constexpr const char* kMarkers = "/nsim/markers";              ///< geometry_msgs/msg/PoseArray
constexpr const char* kRobotPose = "/nsim/robot/pose";         ///< geometry_msgs/msg/PoseStamped
constexpr const char* kJointStates = "/nsim/robot/joint_states";  ///< sensor_msgs/msg/JointState
constexpr const char* kEntryPoint = "/nsim/entry_point";       ///< geometry_msgs/msg/PointStamped
constexpr const char* kTargetPose = "/nsim/target_pose";       ///< geometry_msgs/msg/PoseStamped
constexpr const char* kJointCommand = "/nsim/robot/joint_command";  ///< sensor_msgs/msg/JointState
constexpr const char* kTipToTarget = "/nsim/tip_to_target";    ///< std_msgs/msg/Float64 (m)
}  // namespace ros2_topic

/// The joint names of the KUKA iiwa in JointState messages, in joint order.
const std::vector<std::string>& Ros2JointNames();

/// How the ROS 2 side joins DDS.
struct Ros2Config {
  int domain_id = 0;            ///< the ROS 2 domain (ROS_DOMAIN_ID), 0..232
  std::string config_file;      ///< Cyclone XML file; empty: Cyclone's default (CYCLONEDDS_URI)
  std::string frame_id = "world";  ///< header.frame_id of every message (the world frame W)
  /// A publishing process waits for this many ROS 2 subscribers of each of its streams'
  /// topics before its first message (--ros2-wait), 0..1000; 0: it does not wait.
  int wait_subscribers = 0;

  /// Throws InputError naming the field when a value is out of range or the file is missing.
  void Validate() const;
};

/// The ROS 2 configuration of a process: the domain of --domain if it was given, else the
/// environment's ROS_DOMAIN_ID, else 0 (ROS 2's default); the DDS configuration file of
/// `transport`. Throws InputError for a ROS_DOMAIN_ID that is not a domain id.
Ros2Config Ros2ConfigFor(const TransportConfig& transport, bool domain_given);

/// Which topics a Ros2Mirror writes.
struct Ros2MirrorTopics {
  bool frames = false;         ///< markers, robot pose, joint states, entry point (PublishFrame)
  bool targets = false;        ///< target pose (PublishTarget)
  bool joint_command = false;  ///< with targets: joint targets also as a joint command
  bool distance = false;       ///< tip-to-target distance (PublishDistance)
};

/// Publishes the internal samples as ROS 2 messages on its own participant. Every message is
/// stamped with the sample's simulation time (builtin_interfaces/Time) and frame_id.
class Ros2Mirror {
 public:
  /// Throws InputError for a bad config, std::runtime_error if DDS refuses.
  Ros2Mirror(const Ros2Config& config, const Ros2MirrorTopics& topics);
  ~Ros2Mirror();
  Ros2Mirror(const Ros2Mirror&) = delete;
  Ros2Mirror& operator=(const Ros2Mirror&) = delete;

  /// The markers as a PoseArray (one pose per marker, in marker order, orientation identity);
  /// with a robot also its flange pose (PoseStamped), its joints (JointState named a1..a7,
  /// when it has joints) and, once the skin is punctured, the entry point (PointStamped).
  void PublishFrame(const SensorFrame& frame);
  /// The target's flange pose X_WE (PoseStamped; for a joint target the caller sets X_WE to
  /// the flange pose its joints imply) and, if enabled, a joint target's angles as a joint
  /// command (JointState positions named a1..a7).
  void PublishTarget(const RobotTarget& target);
  /// The true tip-to-target distance (m) as a Float64 (which has no header, so no time).
  void PublishDistance(double distance_m);

  /// Subscribers matched now on ROS 2 topic `topic` (ros2_topic::k...); 0 for a topic this
  /// mirror does not write.
  int subscribers(const char* topic) const;
  /// Waits until each of `topics` has at least `count` matched subscribers. Returns the first
  /// topic still short of them when `timeout_s` passed, or an empty string.
  std::string WaitForSubscribers(int count, const std::vector<const char*>& topics,
                                 double timeout_s) const;
  /// Waits until every reliable subscriber has acknowledged everything; false on timeout.
  bool WaitForAcks(double timeout_s) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// What a Ros2Input has received.
struct Ros2InputCounts {
  uint64_t markers = 0;       ///< valid PoseArrays taken
  uint64_t robot_poses = 0;   ///< valid PoseStampeds taken
  uint64_t joint_states = 0;  ///< valid JointStates taken
  uint64_t entry_points = 0;  ///< valid PointStampeds taken
  uint64_t frames = 0;        ///< SensorFrames assembled
  uint64_t incomplete = 0;    ///< PoseArrays dropped: no robot pose (or required joints) yet
  uint64_t invalid = 0;       ///< messages dropped because they failed validation
  std::string last_invalid;   ///< why the last dropped message was invalid
  int marker_publishers = 0;  ///< publishers matched on /nsim/markers now
};

/// Assembles SensorFrames from ROS 2 topics published by anything (a tracker, a robot
/// driver, direct_sim's mirror): each PoseArray on /nsim/markers makes one frame with the
/// newest PoseStamped on /nsim/robot/pose, the newest JointState on /nsim/robot/joint_states
/// (if any came) and the newest PointStamped on /nsim/entry_point, stamped with the markers'
/// header stamp. A frame is complete once markers and a robot pose have arrived, and joint
/// states with `joints_required` positions when that is not 0 (a joint-space controller cannot
/// use a frame without them); the entry point counts as not punctured until a PointStamped
/// arrives.
class Ros2Input {
 public:
  /// `entry_normal_W`: the skin normal a frame carries with the entry point (a PointStamped
  /// has none): the controller passes the opposite of its planned insertion direction.
  Ros2Input(const Ros2Config& config, const Eigen::Vector3d& entry_normal_W,
            size_t joints_required = 0);
  ~Ros2Input();
  Ros2Input(const Ros2Input&) = delete;
  Ros2Input& operator=(const Ros2Input&) = delete;

  /// Blocks until a message arrives on any of the topics, at most `timeout_s`; false on
  /// timeout.
  bool Wait(double timeout_s);
  /// Takes everything that arrived and appends the frames it completes to `out` (seq from 0
  /// per frame assembled; wall_time_ns the time of taking; applied_seq kNoTarget: a ROS 2
  /// robot does not say which target it executed). Returns how many.
  size_t Take(std::vector<SensorFrame>& out);
  Ros2InputCounts counts() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace nsim::transport
