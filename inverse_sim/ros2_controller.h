#pragma once
// The controller's pump over ROS 2 (inverse_sim run --ros2-io): its markers, robot state and
// entry point come from ROS 2 topics, published by anything (a tracker, a robot driver,
// direct_sim run --ros2), assembled into SensorFrames by a Ros2Input; it answers the newest
// frame (realtime) and publishes the target as /nsim/target_pose and, for the iiwa, as
// /nsim/robot/joint_command. No nsim topics, no start handshake: a ROS 2 source does not
// announce its end, so the run ends when the markers stop for idle_timeout.

#include <Eigen/Core>
#include <string>

#include "common/results/controller_recorder.h"
#include "common/steering/controller_loop.h"
#include "messages/ros2.h"

namespace nsim {

struct ControllerRos2Options {
  transport::Ros2Config ros2;
  double timeout = 3600.0;       ///< give up after this long in all (s)
  double start_timeout = 60.0;   ///< give up if no complete frame came within this (s)
  double idle_timeout = 5.0;     ///< end (0) when no frame came for this long after one (s)
  /// the skin normal of the entry point (a PointStamped has none): the opposite of the
  /// planned insertion direction
  Eigen::Vector3d entry_normal_W = Eigen::Vector3d::UnitZ();
  /// joint positions a frame must carry (7: the iiwa's joint law; 0: none needed)
  size_t joints_required = 0;
  bool quiet = false;
};

/// Runs until the markers stop; fills `info` and returns the exit code: 0 the input went idle,
/// 1 runtime failure (no input, timeout, interrupted, a diverged solve), 2 a model that cannot
/// be built from the scenario.
int RunControllerOverRos2(ControllerLoop& loop, ControllerRecorder& recorder,
                          const ControllerRos2Options& options, ControllerRunInfo* info);

}  // namespace nsim
