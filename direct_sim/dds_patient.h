#pragma once
// direct_sim's pump between the PatientLoop and DDS: the start handshake with the controller
// (its readers matched, its "running" status, the same scenario hash), then per step: publish
// the sensor frame, take the targets (lockstep: wait, bounded, for the answer to frame k - d;
// realtime: whatever arrived), step the loop; the status and the controller's liveliness on
// the side.

#include <string>

#include "common/scene/patient_loop.h"
#include "direct_sim/patient_outputs.h"
#include "direct_sim/scenario_loader.h"
#include "messages/transport.h"

namespace nsim {

/// Runs the whole insertion over DDS; fills `info` and returns the exit code (0 completed;
/// 1 runtime failure: no or lost controller, diverged, interrupted; 2 the controller runs
/// another scenario).
int RunPatientOverDds(PatientLoop& loop, PatientOutputs& outputs, const RunConfig& run,
                      const transport::TransportConfig& transport, uint64_t scenario_hash,
                      bool quiet, PatientRunInfo* info);

}  // namespace nsim
