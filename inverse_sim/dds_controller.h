#pragma once
// The controller's pump between DDS and the ControllerLoop: it reads direct_sim's sensor
// frames and status, answers frames with robot targets (lockstep: every frame in order;
// realtime: the newest, older ones only feed the predictor), and stops when direct_sim
// finishes, dies, or sends a different scenario (its status's scenario hash).

#include <optional>
#include <string>

#include "common/results/controller_recorder.h"
#include "common/steering/controller_loop.h"
#include "messages/ros2.h"
#include "messages/transport.h"

namespace nsim {

struct ControllerPumpOptions {
  transport::TransportConfig transport;
  bool lockstep = true;
  double timeout = 3600.0;       ///< give up after this long in all (s)
  double start_timeout = 60.0;   ///< give up if direct_sim is not seen within this (s)
  /// give up when direct_sim's writers stay not alive this long (s): a stalled direct_sim (or
  /// this process, stopped and resumed, seeing its leases expire) may come back
  double direct_timeout = 30.0;
  uint64_t scenario_hash = 0;    ///< ours; direct_sim's must equal it
  /// realtime only: each frame is taken up this long after it arrived and each target written
  /// this long after it was computed (s, each way; 0: none): a slower network emulated, the
  /// latency the controller then measures and predicts over
  double link_delay = 0.0;
  bool quiet = false;
  /// --ros2: every target also on /nsim/target_pose (messages/ros2.h)
  std::optional<transport::Ros2Config> ros2;
};

/// Runs until the end of the insertion; fills `info` (ending, frame counts, latencies) and
/// returns the exit code: 0 direct_sim finished, 1 runtime failure (direct_sim lost, timeout,
/// interrupted, a diverged solve), 2 bad input (a model that cannot be built from the scenario,
/// or a direct_sim running another scenario).
int RunControllerOverDds(ControllerLoop& loop, ControllerRecorder& recorder,
                         const ControllerPumpOptions& options, ControllerRunInfo* info);

}  // namespace nsim
