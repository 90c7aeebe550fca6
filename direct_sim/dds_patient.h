#pragma once
// direct_sim's pump between the PatientLoop and DDS: the start handshake with the controller
// (its readers matched, its "running" status, the same scenario hash), then per step: publish
// the sensor frame, take the targets (lockstep: wait, bounded, for the answer to frame k - d;
// realtime: whatever arrived), step the loop; the status and the controller's liveliness on
// the side; optionally a ROS 2 mirror of the frames.

#include <optional>
#include <string>

#include "common/scene/patient_loop.h"
#include "direct_sim/patient_outputs.h"
#include "direct_sim/scenario_loader.h"
#include "messages/ros2.h"
#include "messages/transport.h"

namespace nsim {

/// Runs the whole insertion over DDS; fills `info` and returns the exit code (0 completed;
/// 1 runtime failure: no or lost controller, diverged, interrupted; 2 the controller runs
/// another scenario). With `ros2` every frame and the true tip-to-target distance are also
/// published on the ROS 2 topics (messages/ros2.h).
int RunPatientOverDds(PatientLoop& loop, PatientOutputs& outputs, const RunConfig& run,
                      const transport::TransportConfig& transport,
                      const std::optional<transport::Ros2Config>& ros2, uint64_t scenario_hash,
                      bool quiet, PatientRunInfo* info);

}  // namespace nsim
