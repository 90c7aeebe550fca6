// inverse_sim: the controller (registration, prediction, Jacobian, control law) and its tools.
#include "common/core/cli.h"
#include "common/core/library_threads.h"
#include "inverse_sim/predict_eval.h"
#include "inverse_sim/record.h"
#include "inverse_sim/run_command.h"

int main(int argc, char** argv) {
  nsim::UseOneLibraryThreadUnlessSet(argv);
  return nsim::RunSubcommands(
      "inverse_sim", "The inverse simulation: the controller and its tools.",
      {{"run", "the controller in the closed loop (--config S.yaml)", nsim::RunInverseSim},
       {"record", "record received marker frames to CSV (--out OUT.csv)", nsim::RunRecord},
       {"predict-eval", "offline evaluation of marker prediction (--markers IN.csv)",
        nsim::RunPredictEval}},
      argc, argv);
}
