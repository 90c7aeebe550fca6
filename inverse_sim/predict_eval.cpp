#include "inverse_sim/predict_eval.h"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/markers/marker_csv.h"
#include "common/prediction/evaluation.h"
#include "common/prediction/marker_predictor.h"
#include "inverse_sim/predict_eval_report.h"

namespace nsim {
namespace {

std::vector<std::string> SplitList(const std::string& text, const std::string& what) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) {
    const auto b = part.find_first_not_of(" \t");
    const auto e = part.find_last_not_of(" \t");
    if (b == std::string::npos) throw InputError(Str(what, ": empty item in list '", text, "'"));
    out.push_back(part.substr(b, e - b + 1));
  }
  if (out.empty())
    throw InputError(Str(what, ": expected a comma-separated list, got '", text, "'"));
  return out;
}

std::vector<double> ParseHorizons(const std::string& text) {
  std::vector<double> out;
  for (const auto& item : SplitList(text, "--horizon")) {
    const double h = ParseDouble(item, "--horizon");
    if (!(h >= 0)) throw InputError(Str("--horizon: values must be >= 0 (s), got ", h));
    out.push_back(h);
  }
  return out;
}

std::vector<int> ParseOrders(const std::string& text) {
  std::vector<int> out;
  for (const auto& item : SplitList(text, "--order")) {
    const long order = ParseInt(item, "--order");
    if (order < 1 || order > 3)
      throw InputError(Str("--order: values must be 1, 2 or 3, got ", order));
    out.push_back(static_cast<int>(order));
  }
  return out;
}

// dB values, or "inf" for no noise
std::vector<double> ParseSnrs(const std::string& text) {
  std::vector<double> out;
  for (const auto& item : SplitList(text, "--snr-db")) {
    if (item == "inf" || item == "none") {
      out.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    out.push_back(ParseDouble(item, "--snr-db"));
  }
  return out;
}

std::vector<PredictionFilterKind> ParseFilters(const std::string& text) {
  std::vector<PredictionFilterKind> out;
  for (const auto& item : SplitList(text, "--filter")) {
    try {
      out.push_back(ParsePredictionFilter(item));
    } catch (const InputError& e) {
      throw InputError(Str("--filter: ", e.what()));
    }
  }
  return out;
}

int ParseCount(const CommandLine& cli, const std::string& name, long lo) {
  const long v = cli.GetInt(name);
  if (v < lo || v > 1000000)
    throw InputError(Str("--", name, " must be in [", lo, ", 1000000], got ", v));
  return static_cast<int>(v);
}

// the settings of one evaluation, from the command line
struct PredictEvalOptions {
  std::vector<double> horizons;
  std::vector<int> orders;
  std::vector<double> snrs;
  std::vector<PredictionFilterKind> filters;
  long seed = 1;
  PredictionConfig base;  // the predictor settings common to every combination
};

// parses and checks the lists and the predictor settings; every combination validated before
// the (longer) evaluation
PredictEvalOptions ReadOptions(const CommandLine& cli) {
  PredictEvalOptions o;
  o.horizons = ParseHorizons(cli.GetString("horizon"));
  o.orders = ParseOrders(cli.GetString("order"));
  o.snrs = ParseSnrs(cli.GetString("snr-db"));
  o.filters = ParseFilters(cli.GetString("filter"));
  o.seed = cli.GetInt("seed");
  if (o.seed < 0) throw InputError(Str("--seed must be >= 0, got ", o.seed));

  PredictionConfig& base = o.base;
  base.optimize_window = cli.GetFlag("optimize-window");
  base.window = ParseCount(cli, "window", 1);
  base.window_max = ParseCount(cli, "window-max", 1);
  base.pca_window = ParseCount(cli, "pca-window", 1);
  base.pca_update_interval = ParseCount(cli, "pca-interval", 0);
  base.search_interval = ParseCount(cli, "search-interval", 0);
  base.search_lead = ParseCount(cli, "search-lead", 1);
  base.kalman_harmonics = ParseCount(cli, "kalman-harmonics", 1);
  for (PredictionFilterKind f : o.filters) {
    for (int order : o.orders) {
      PredictionConfig c = base;
      c.filter = f;
      c.order = order;
      c.Validate();
    }
  }
  return o;
}

// every combination of SNR, filter, (LF) order and horizon, in that nesting
std::vector<PredictEvalSetting> EvaluateAll(const MarkerStream& clean,
                                            const PredictEvalOptions& o) {
  std::vector<PredictEvalSetting> settings;
  for (double snr : o.snrs) {
    // one noise realization per SNR: the same seed scales the same draws
    const MarkerStream measured = AddWhiteNoise(clean, snr, static_cast<uint64_t>(o.seed));
    std::vector<double> measured_snr(clean.num_markers, std::numeric_limits<double>::infinity());
    if (!std::isinf(snr)) {
      for (int m = 0; m < clean.num_markers; ++m)
        measured_snr[m] = MeasureSnrDb(clean, measured, m);
    }
    for (PredictionFilterKind f : o.filters) {
      // orders only matter for the polynomial filter
      const std::vector<int> filter_orders =
          f == PredictionFilterKind::kLinear ? o.orders : std::vector<int>{0};
      for (int order : filter_orders) {
        for (double h : o.horizons) {
          PredictionConfig c = o.base;
          c.filter = f;
          c.order = order > 0 ? order : o.base.order;
          PredictEvalSetting s{
              f, order, snr, h, EvaluatePrediction(measured, clean, c, h), measured_snr};
          settings.push_back(std::move(s));
        }
      }
    }
  }
  return settings;
}

// the PNGs from the CSVs, by scripts/plot_results.py; without Python and matplotlib the
// evaluation still succeeds, and the message says how to draw them later
void MakeFigures(const std::string& script, const std::string& dir) {
  std::cout << std::flush;  // before the script's own lines
  std::string why;
  if (DrawPredictEvalFigures(script, dir, &why)) {
    std::cout << "predict-eval: figures " << dir << "/marker<m>.png\n";
    return;
  }
  std::cerr << "predict-eval: the figures (marker<m>.png) were not made: " << why
            << "; the series are in " << dir << "/marker<m>.csv; make them with: /usr/bin/python3 "
            << script << " predict-eval " << dir << "\n";
}

}  // namespace

int RunPredictEval(int argc, char** argv) {
  CommandLine cli(
      "inverse_sim predict-eval --markers IN.csv --out DIR [options]",
      "Offline evaluation of marker prediction (thesis §5.2.1): adds white Gaussian noise at each "
      "SNR (relative to each marker's centred signal power), runs the predictor causally and "
      "reports RMS (eq. 4.19), nRMS (eq. 4.20, vs. the measurement delayed by the horizon) and "
      "jitter of the 3D position error against the noise-free input, for every combination of "
      "the comma-separated --filter, --order, --snr-db and --horizon values. Writes "
      "DIR/predict_eval.json, DIR/table.txt, the series of the first setting per marker in "
      "DIR/marker<m>.csv and their plots DIR/marker<m>.png (drawn by scripts/plot_results.py "
      "predict-eval DIR with /usr/bin/python3 and matplotlib).");
  cli.Option("markers", "FILE", "input marker CSV (t,m0_x,m0_y,m0_z,...)", "", true)
      .Option("out", "DIR", "output directory (created if missing)", "", true)
      .Option("horizon", "S[,S..]", "prediction horizons (s)", "0.16")
      .Option("order", "N[,N..]", "LF polynomial orders (1, 2, 3)", "2")
      .Option("snr-db", "DB[,DB..]", "noise levels (dB), 'inf' for none", "inf")
      .Option("filter", "F[,F..]", "predictors: lf, none, kalman", "lf")
      .Flag("optimize-window", "choose WF by golden search (Algorithm 1)")
      .Option("window", "WF", "LF regression window when not optimized (samples)", "10")
      .Option("window-max", "WL", "window search range [order+1, WL-1] (samples)", "60")
      .Option("pca-window", "WP", "PCA rolling buffer (samples)", "300")
      .Option("pca-interval", "K", "recompute the PCA every K samples (0: once)", "1")
      .Option("search-interval", "K",
              "rerun the window search / period estimate every K samples (0: once)", "0")
      .Option("search-lead", "N", "samples ahead the window-search cost predicts", "1")
      .Option("kalman-harmonics", "K", "harmonics of the kalman breathing model", "2")
      .Option("seed", "N", "noise seed", "1")
      .Flag("no-plots", "skip the plot series (CSV) and figures (PNG)")
      .Flag("no-figures", "write the plot series (CSV) but do not draw the PNGs")
      .Option("plot-script", "FILE", "draws the PNGs (/usr/bin/python3 FILE predict-eval DIR)",
              NSIM_PLOT_SCRIPT);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const PredictEvalOptions options = ReadOptions(cli);

  const std::string input = cli.GetString("markers");
  const MarkerStream clean = ReadMarkerCsv(input);
  if (clean.frames.size() < 3)
    throw InputError(Str(input, ": needs at least 3 frames, got ", clean.frames.size()));
  // the metrics resample the stream uniformly: one absurd timestamp would stretch the grid
  // over a long empty stretch (a 440 % nRMS); a tracker's sampling jitters by a few percent
  // and a lost frame doubles one interval, so an interval over 10 times the median is a broken
  // time column
  CheckMarkerSampling(clean, input, 10.0, std::numeric_limits<double>::infinity());
  const std::filesystem::path out_dir = cli.GetString("out");
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir))
    throw InputError(
        Str("--out: cannot create directory '", out_dir.string(), "': ", ec.message()));

  const std::vector<PredictEvalSetting> settings = EvaluateAll(clean, options);
  const std::string json_path = (out_dir / "predict_eval.json").string();
  WritePredictEvalJson(json_path, input, clean, options.seed, options.base, settings);
  const std::string table =
      PredictEvalTable(settings, options.snrs, options.horizons, options.base);
  std::cout << table;
  WriteTextFile((out_dir / "table.txt").string(), table);
  std::cout << "predict-eval: " << settings.size() << " settings, wrote " << json_path << "\n";
  if (!cli.GetFlag("no-plots")) {
    for (int m = 0; m < clean.num_markers; ++m)
      WriteMarkerSeriesCsv((out_dir / Str("marker", m, ".csv")).string(), settings.front(), m);
    if (!cli.GetFlag("no-figures")) MakeFigures(cli.GetString("plot-script"), out_dir.string());
  }
  return 0;
}

}  // namespace nsim
