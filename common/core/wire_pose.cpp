#include "common/core/wire_pose.h"

namespace nsim {

WirePose ToWirePose(const Eigen::Isometry3d& X) {
  return {X.translation(), Eigen::Quaterniond(X.linear())};
}

Eigen::Isometry3d FromWirePose(const WirePose& w) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = w.q.normalized().toRotationMatrix();
  X.translation() = w.p;
  return X;
}

Eigen::Isometry3d ThroughWire(const Eigen::Isometry3d& X) { return FromWirePose(ToWirePose(X)); }

SensorFrame ThroughWire(SensorFrame frame) {
  if (frame.has_robot) frame.X_WE = ThroughWire(frame.X_WE);
  return frame;
}

RobotTarget ThroughWire(RobotTarget target) {
  target.X_WE = ThroughWire(target.X_WE);
  return target;
}

}  // namespace nsim
