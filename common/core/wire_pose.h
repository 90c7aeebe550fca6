#pragma once
// How a rigid pose travels between the processes: as a position and a unit quaternion
// (messages/nsim_msgs.idl Pose). The conversion rotation matrix -> quaternion -> matrix is
// exact to about 1e-16, not bitwise; messages/convert.cpp uses these functions, and the
// in-process closed loop passes its frames and targets through ThroughWire, so both give the
// same run to the last digit.

#include <Eigen/Geometry>

#include "common/core/samples.h"

namespace nsim {

/// Position and rotation of a pose as sent: the quaternion of X.linear() (w, x, y, z).
struct WirePose {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

WirePose ToWirePose(const Eigen::Isometry3d& X);
/// The pose a receiver builds: the normalized quaternion's rotation and the position.
Eigen::Isometry3d FromWirePose(const WirePose& w);

/// What sending does to a pose: FromWirePose(ToWirePose(X)).
Eigen::Isometry3d ThroughWire(const Eigen::Isometry3d& X);
/// The frame / target a receiver gets (every pose through the wire, the rest exact).
SensorFrame ThroughWire(SensorFrame frame);
RobotTarget ThroughWire(RobotTarget target);

}  // namespace nsim
