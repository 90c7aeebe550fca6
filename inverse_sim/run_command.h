#pragma once
// `inverse_sim run --config S.yaml`: the controller process (thesis §3.2-3.3, §4.1.6).

namespace nsim {

/// Subscribes MarkerFrame, RobotState, EntryPoint and SimStatus; registers the liver model to
/// the (predicted) markers; answers each marker frame with a RobotTarget (answers_seq = the
/// frame's seq); publishes its own SimStatus; writes DIR/summary.json and DIR/inverse.csv.
/// Ends when direct_sim reports finished (0), or when its liveliness is lost (1).
int RunInverseSim(int argc, char** argv);

}  // namespace nsim
