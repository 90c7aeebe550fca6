#pragma once
// The closed loop in one process (DESIGN.md "Time, modes and determinism"): the patient loop
// and the controller loop stepped in lockstep with a simulated latency of d steps, frames and
// targets passed as they would cross the wire (poses through their quaternion form). The
// same rule as the DDS lockstep run (LockstepTargets), so the same scenario gives the same
// timeseries.csv and final error to the last digit, without the network; for tests and
// batches.

#include <cstdint>
#include <functional>
#include <memory>

#include "common/results/controller_recorder.h"
#include "common/results/patient_recorder.h"
#include "common/scene/patient_loop.h"
#include "common/steering/controller_loop.h"
#include "direct_sim/patient_outputs.h"
#include "direct_sim/scenario_loader.h"

namespace nsim {

/// For experiments (direct_sim run --in-process --restart-controller-at S): at step at_step
/// (-1: never) the controller is replaced by make()'s, which sees the frames from then on (its
/// model catches up from the first, ControllerLoop), and the robot's command and the answers
/// not yet applied are dropped: a new inverse_sim taking over without the frame history
/// (direct_sim's ControllerWatch; over DDS in lockstep the new one gets the history instead).
struct ControllerRestart {
  int64_t at_step = -1;
  std::function<std::unique_ptr<ControllerLoop>()> make;
};

/// For experiments (direct_sim run --in-process --loss PCT): each frame and each target is lost
/// with probability percent / 100, drawn from `seed` (two streams), as a lossy network would
/// lose them under the reliable keep-last-1 streams (LossyLink): a lost frame never reaches the
/// controller, a lost target never reaches the robot, which keeps its command until a newer
/// target arrives. 0: the link of every other lockstep run.
struct LinkLoss {
  double percent = 0.0;
  uint64_t seed = 1;
};

/// Runs the insertion; fills both infos and returns the exit code (0 completed, 1 runtime
/// failure: diverged, interrupted; 2 a controller model that cannot be built from the
/// scenario). `controller` is the one running at the end.
int RunClosedLoopInProcess(PatientLoop& patient, PatientOutputs& outputs,
                           std::unique_ptr<ControllerLoop>& controller,
                           ControllerRecorder& controller_recorder, const RunConfig& run,
                           PatientRunInfo* patient_info, ControllerRunInfo* controller_info,
                           const ControllerRestart& restart = {}, const LinkLoss& loss = {});

}  // namespace nsim
