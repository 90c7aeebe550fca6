#include "direct_sim/in_process.h"

#include <cmath>
#include <iostream>

#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/lossy_link.h"
#include "common/core/wire_pose.h"
#include "common/scene/lockstep_targets.h"

namespace nsim {
namespace {

// the controller's answer to the patient's current frame, as the patient would receive it
std::optional<RobotTarget> Answer(ControllerLoop& controller, ControllerRecorder& recorder,
                                  const PatientLoop& patient) {
  const uint64_t before = controller.counts().answered;
  std::optional<RobotTarget> target = controller.Step(ThroughWire(patient.frame()));
  if (controller.counts().answered > before) recorder.AddAnswer(controller);
  if (target) *target = ThroughWire(*target);
  return target;
}

}  // namespace

int RunClosedLoopInProcess(PatientLoop& patient, PatientOutputs& outputs,
                           std::unique_ptr<ControllerLoop>& controller,
                           ControllerRecorder& controller_recorder, const RunConfig& run,
                           PatientRunInfo* pinfo, ControllerRunInfo* cinfo,
                           const ControllerRestart& restart, const LinkLoss& loss) {
  const int64_t steps = static_cast<int64_t>(std::llround(run.duration / patient.config().scene.time_step));
  LockstepTargets delay(run.latency_steps);
  LossyLink frames_link(loss.percent, loss.seed, 1), targets_link(loss.percent, loss.seed, 2);
  const double start = MonotonicSeconds();
  int code = 0;
  try {
    for (int64_t k = 0; k < steps; ++k) {
      if (InterruptRequested()) {
        pinfo->exit = cinfo->ending = "interrupted";
        code = 1;
        break;
      }
      if (!patient.healthy()) {
        ReportFault(patient, pinfo);
        code = 1;
        break;
      }
      if (k == restart.at_step && restart.make) {
        controller = restart.make();
        delay = LockstepTargets(run.latency_steps);
        patient.DropCommand();
        ++pinfo->takeovers;
      }
      outputs.OnFrame(patient);
      if (!frames_link.Drop()) {
        std::optional<RobotTarget> target = Answer(*controller, controller_recorder, patient);
        if (target && !targets_link.Drop()) delay.Add(*target);
      }
      // the controller gave no answer (or the link lost the frame or the answer)
      if (!delay.Ready(k)) ++pinfo->lockstep_timeouts;
      patient.Step(delay.TakeFor(k));
      patient.Prefetch();
      outputs.OnStep(patient, steps);
    }
    if (code == 0 && !patient.healthy()) {
      ReportFault(patient, pinfo);
      code = 1;
    } else if (code == 0) {  // the final state, answered like over DDS
      outputs.OnFrame(patient);
      Answer(*controller, controller_recorder, patient);
    }
  } catch (const SolverError& e) {
    std::cerr << "direct_sim run: runtime failure at t = " << patient.time() << " s: " << e.what()
              << "\n";
    pinfo->exit = "diverged";
    cinfo->ending = "solver_failed";
    code = 1;
  }
  pinfo->wall_time = MonotonicSeconds() - start;
  pinfo->link_loss_percent = loss.percent;
  pinfo->frames_lost = frames_link.lost();
  pinfo->targets_lost = targets_link.lost();
  if (code == 0) cinfo->ending = "direct_finished";
  cinfo->frames_received = controller->counts().observed;
  cinfo->frames_missing = frames_link.lost();  // never reached the controller
  return code;
}

}  // namespace nsim
