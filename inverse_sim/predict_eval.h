#pragma once
// `inverse_sim predict-eval`: offline evaluation of marker prediction on a recorded marker
// stream (thesis §5.2.1, figs. 5.3-5.6): noise at given SNRs, filters, orders and horizons, with
// a JSON report, a text table, and plot series (CSV) drawn by scripts/plot_results.py (PNG).

namespace nsim {

/// Runs the `predict-eval` subcommand; argv[0] is "predict-eval". Required: --markers IN.csv
/// --out DIR. Lists (comma-separated) for --horizon, --order, --snr-db and --filter make one
/// setting per combination. Writes DIR/predict_eval.json, DIR/table.txt (also printed) and,
/// unless --no-plots, the plot series of the first setting DIR/marker<m>.csv and (unless
/// --no-figures) their figures DIR/marker<m>.png, drawn by `/usr/bin/python3 --plot-script
/// predict-eval DIR` (scripts/plot_results.py); when that cannot run, a message on stderr says
/// so and how to draw them. Returns 0 (also after --help, and when the figures were not made).
/// Throws InputError on bad options, values or input data.
int RunPredictEval(int argc, char** argv);

}  // namespace nsim
