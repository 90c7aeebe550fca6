#pragma once
// The report of `inverse_sim predict-eval` on the evaluated settings: the JSON file, the text
// table (thesis figs. 5.3-5.6 style: rows SNR, columns horizon) and the per-marker plot series
// (CSV; the figures are drawn from them by scripts/plot_results.py).
// Lengths in the report are mm, ratios %.

#include <string>
#include <vector>

#include "common/markers/marker_csv.h"
#include "common/prediction/evaluation.h"
#include "common/prediction/marker_predictor.h"

namespace nsim {

/// One evaluated combination of filter, order, noise level and horizon.
struct PredictEvalSetting {
  PredictionFilterKind filter;
  int order;       ///< LF polynomial order (0 for the other filters)
  double snr_db;   ///< noise level (dB), +inf for none
  double horizon;  ///< prediction horizon (s)
  PredictionEvaluation evaluation;
  std::vector<double> measured_snr_db;  ///< per marker (dB), +inf without noise
};

/// Writes the JSON report to `path`: the input (`input`, its stream `clean`), the noise seed,
/// the shared predictor settings `base`, the mean and per-marker metrics of every setting, and
/// `plot_setting`, the index of the setting whose series are in DIR/marker<m>.csv (0).
/// InputError when the file cannot be written.
void WritePredictEvalJson(const std::string& path, const std::string& input,
                          const MarkerStream& clean, long seed, const PredictionConfig& base,
                          const std::vector<PredictEvalSetting>& settings);

/// The text table: one block per (filter, order) in evaluation order, with RMS / nRMS mean over
/// the markers and nRMS per marker, for every SNR in `snrs` and horizon in `horizons`.
/// Precondition: `settings` holds every combination of them.
std::string PredictEvalTable(const std::vector<PredictEvalSetting>& settings,
                             const std::vector<double>& snrs, const std::vector<double>& horizons,
                             const PredictionConfig& base);

/// The series plotted for marker m in setting `s`, as CSV at `path`: header
/// `t,delayed_pc_mm,reference_pc_mm,predicted_pc_mm,error_predicted_mm,error_delayed_mm`, one
/// row per grid time (s): the first principal component (of the reference) of the measurement
/// delayed by h, of the reference and of the prediction, and the 3D error with and without
/// prediction (mm). scripts/plot_results.py predict-eval draws them. InputError when the file
/// cannot be written.
void WriteMarkerSeriesCsv(const std::string& path, const PredictEvalSetting& s, int m);

/// Runs `/usr/bin/python3 SCRIPT predict-eval DIR` (scripts/plot_results.py: DIR/marker<m>.png
/// from DIR/marker<m>.csv and DIR/predict_eval.json) and waits for it. True when it succeeded;
/// otherwise false with `why` saying what was missing or failed.
bool DrawPredictEvalFigures(const std::string& script, const std::string& dir, std::string* why);

/// Writes `text` to `path`; InputError "cannot write '<path>'" when it cannot be opened.
void WriteTextFile(const std::string& path, const std::string& text);

}  // namespace nsim
