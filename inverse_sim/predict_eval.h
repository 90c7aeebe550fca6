#pragma once
// `inverse_sim predict-eval`: offline evaluation of marker prediction on a recorded marker
// stream (thesis §5.2.1, figs. 5.3-5.6): noise at given SNRs, filters, orders and horizons, with
// a JSON report, a text table and PNG plots.

namespace nsim {

/// Runs the `predict-eval` subcommand; argv[0] is "predict-eval". Required: --markers IN.csv
/// --out DIR. Lists (comma-separated) for --horizon, --order, --snr-db and --filter make one
/// setting per combination. Writes DIR/predict_eval.json, DIR/table.txt (also printed) and,
/// unless --no-plots, DIR/marker<m>.png for the first setting. Returns 0 (also after --help).
/// Throws InputError on bad options, values or input data.
int RunPredictEval(int argc, char** argv);

}  // namespace nsim
