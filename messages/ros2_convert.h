#pragma once
// The one place where the ROS 2 message types (generated from messages/ros2/*.idl) and the
// internal samples (common/core/samples.h) meet. Internal to messages/.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "geometry_msgs.h"
#include "sensor_msgs.h"
#include "std_msgs.h"

namespace nsim::transport {

/// A simulation time (s) as builtin_interfaces/Time: sec = floor(t), nanosec in
/// 0..999999999, rounded to the nanosecond.
builtin_interfaces_msg_dds__Time_ ToRos2Time(double t);
double FromRos2Time(const builtin_interfaces_msg_dds__Time_& m);

/// Storage that the strings and sequences of outgoing messages point into; reused between
/// writes (valid until its next use).
struct Ros2Scratch {
  std::vector<geometry_msgs_msg_dds__Pose_> poses;
  std::vector<double> positions;
  std::vector<char*> names;
};

/// The header of an outgoing message; `frame_id` must outlive the message.
void ToRos2Header(double t, const std::string& frame_id, std_msgs_msg_dds__Header_& m);

/// Markers as a PoseArray: one pose per marker, in marker order, orientation identity.
void ToRos2Markers(double t, const std::vector<Eigen::Vector3d>& p_WM,
                   const std::string& frame_id, geometry_msgs_msg_dds__PoseArray_& m,
                   Ros2Scratch& scratch);
/// A rigid pose as a PoseStamped (the rotation as its unit quaternion, w >= 0 not enforced).
void ToRos2Pose(double t, const Eigen::Isometry3d& X, const std::string& frame_id,
                geometry_msgs_msg_dds__PoseStamped_& m);
/// Joint angles as a JointState: positions named a1..a7, no velocities or efforts.
void ToRos2Joints(double t, const std::vector<double>& q, const std::string& frame_id,
                  sensor_msgs_msg_dds__JointState_& m, Ros2Scratch& scratch);
/// A point as a PointStamped.
void ToRos2Point(double t, const Eigen::Vector3d& p, const std::string& frame_id,
                 geometry_msgs_msg_dds__PointStamped_& m);

/// The reverse conversions of received messages. Each returns an empty string if the message
/// is valid, otherwise what is wrong with it (a frame other than `frame_id`, a value that is
/// not finite, a quaternion that is not unit, a joint missing); the caller then drops it.
std::string FromRos2Markers(const geometry_msgs_msg_dds__PoseArray_& m,
                            const std::string& frame_id, double* t,
                            std::vector<Eigen::Vector3d>* p_WM);
std::string FromRos2Pose(const geometry_msgs_msg_dds__PoseStamped_& m, const std::string& frame_id,
                         double* t, Eigen::Isometry3d* X);
/// The positions of the joints a1..a7 when the message names its joints (in any order, others
/// ignored), otherwise all its positions in order.
std::string FromRos2Joints(const sensor_msgs_msg_dds__JointState_& m, std::vector<double>* q);
std::string FromRos2Point(const geometry_msgs_msg_dds__PointStamped_& m,
                          const std::string& frame_id, double* t, Eigen::Vector3d* p);

}  // namespace nsim::transport
