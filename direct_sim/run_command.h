#pragma once
// `direct_sim run --config S.yaml`: the direct simulation. Each step applies the latest valid
// RobotTarget (through the safety gate and the robot's limits), advances the patient scene,
// publishes MarkerFrame, RobotState, EntryPoint and SimStatus, and logs the true tip-to-target
// distance and e_p. Modes: realtime (wall-clock paced) and lockstep (waits, with a bound, for
// the target answering frame k - latency_steps before step k; deterministic given the seed).
// --no-controller inserts along the planned path at insertion.speed without any peer.
// Outputs in --out DIR: summary.json, timeseries.csv, vtk/ snapshots (--vtk-every N), the view
// (live window, or view.avi) and view.png (last frame).

namespace nsim {

/// Runs the `run` subcommand; argv[0] is "run". Returns the exit code (0 success, 1 runtime
/// failure: lost controller, diverged simulation, interrupted); throws InputError on bad input.
int RunDirect(int argc, char** argv);

}  // namespace nsim
