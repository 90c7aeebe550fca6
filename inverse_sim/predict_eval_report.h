#pragma once
// The report of `inverse_sim predict-eval` on the evaluated settings: the JSON file, the text
// table (thesis figs. 5.3-5.6 style: rows SNR, columns horizon) and the per-marker plots.
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
/// the shared predictor settings `base`, and the mean and per-marker metrics of every setting.
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

/// PNG of marker m in setting `s`: its first principal component (measured delayed by h,
/// reference, prediction) above the 3D error with and without prediction.
void WriteMarkerPlot(const std::string& path, const PredictEvalSetting& s, int m);

/// Writes `text` to `path`; InputError "cannot write '<path>'" when it cannot be opened.
void WriteTextFile(const std::string& path, const std::string& text);

}  // namespace nsim
