// direct_sim: the patient and the robot (the ground truth of the closed loop).
#include "common/core/cli.h"
#include "common/core/library_threads.h"
#include "direct_sim/breathe_command.h"
#include "direct_sim/replay.h"
#include "direct_sim/run_command.h"

int main(int argc, char** argv) {
  nsim::UseOneLibraryThreadUnlessSet(argv);
  return nsim::RunSubcommands(
      "direct_sim", "The direct simulation: the patient, the robot and the needle.",
      {{"run", "simulate the patient and the robot (--config S.yaml)", nsim::RunDirect},
       {"replay", "publish a recorded marker stream (--markers IN.csv)", nsim::RunReplay},
       {"breathe", "write a synthetic breathing marker stream (--out OUT.csv)", nsim::RunBreathe}},
      argc, argv);
}
