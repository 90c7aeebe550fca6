#include "inverse_sim/predict_eval.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/markers/marker_csv.h"
#include "common/plot/line_plot.h"
#include "common/prediction/evaluation.h"
#include "common/prediction/marker_predictor.h"
#include "common/prediction/pca_buffer.h"

namespace nsim {
namespace {

constexpr double kMm = 1e3;       // m -> mm
constexpr double kPercent = 100;  // ratio -> %

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

std::string SnrLabel(double snr_db) {
  if (std::isinf(snr_db)) return "no noise";
  std::ostringstream out;
  out << snr_db << " dB";
  return out.str();
}

std::string Fixed(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, v);
  return text;
}

std::string Pad(const std::string& s, size_t width) {  // right-aligned
  return s.size() >= width ? s : std::string(width - s.size(), ' ') + s;
}

// one evaluated combination
struct Setting {
  PredictionFilterKind filter;
  int order;  // LF only
  double snr_db;
  double horizon;
  PredictionEvaluation evaluation;
  std::vector<double> measured_snr_db;  // per marker
};

double MeanOver(const Setting& s, double MarkerEvaluation::*field) {
  double sum = 0;
  for (const auto& m : s.evaluation.markers) sum += m.*field;
  return sum / s.evaluation.markers.size();
}

// PC of the rows of y (#samples x 3) along the reference's first principal direction (mm)
std::vector<double> AlongAxis(const Eigen::MatrixXd& y, const PrincipalAxes& axes) {
  std::vector<double> out(y.rows());
  for (long i = 0; i < y.rows(); ++i) out[i] = kMm * axes.Project(y.row(i).transpose());
  return out;
}

void WriteMarkerPlot(const std::string& path, const Setting& s, int m) {
  const MarkerEvaluation& e = s.evaluation.markers[m];
  const std::vector<double>& t = s.evaluation.t_grid;
  PcaBuffer buffer(static_cast<int>(e.reference.rows()));
  for (long i = 0; i < e.reference.rows(); ++i) buffer.Push(t[i], e.reference.row(i).transpose());
  PrincipalAxes axes;
  buffer.CalcPrincipalAxes(&axes);

  const std::string setting = Str(
      ToString(s.filter), s.filter == PredictionFilterKind::kLinear ? Str(" order ", s.order) : "",
      ", ", SnrLabel(s.snr_db), ", h = ", s.horizon, " s");
  PlotConfig top;
  top.title = Str("marker ", m, ": first principal component (", setting, ")");
  top.x_label = "time (s)";
  top.y_label = "PC (mm)";
  LinePlot signal(top);
  PlotSeries delayed{"measured, delayed by h", t, AlongAxis(e.delayed, axes),
                     cv::Scalar(170, 170, 170), 1};
  PlotSeries reference{"reference", t, AlongAxis(e.reference, axes), cv::Scalar(40, 40, 40), 2};
  PlotSeries predicted{"prediction", t, AlongAxis(e.predicted, axes), cv::Scalar(180, 119, 31), 2};
  signal.Add(delayed).Add(reference).Add(predicted);

  PlotConfig bottom;
  bottom.title = Str("3D error: prediction RMS ", Fixed(kMm * e.rms, 3), " mm, nRMS ",
                     Fixed(kPercent * e.nrms, 1), " %; no prediction RMS ",
                     Fixed(kMm * e.rms_delayed, 3), " mm");
  bottom.x_label = "time (s)";
  bottom.y_label = "error (mm)";
  bottom.y_min = 0.0;
  LinePlot error(bottom);
  std::vector<double> err_pred(t.size()), err_none(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    err_pred[i] = kMm * (e.predicted.row(i) - e.reference.row(i)).norm();
    err_none[i] = kMm * (e.delayed.row(i) - e.reference.row(i)).norm();
  }
  error.Add(PlotSeries{"no prediction", t, err_none, cv::Scalar(170, 170, 170), 1});
  error.Add(PlotSeries{"prediction", t, err_pred, cv::Scalar(40, 39, 214), 1});
  WritePng(path, StackVertically({signal.Render(), error.Render()}));
}

std::string MakeTable(const std::vector<Setting>& settings, const std::vector<double>& snrs,
                      const std::vector<double>& horizons, const PredictionConfig& base) {
  std::ostringstream out;
  const size_t cell = 18;
  // one block per (filter, order), in the order they were evaluated
  std::vector<std::pair<PredictionFilterKind, int>> blocks;
  for (const auto& s : settings) {
    const std::pair<PredictionFilterKind, int> key{s.filter, s.order};
    bool seen = false;
    for (const auto& b : blocks) seen = seen || b == key;
    if (!seen) blocks.push_back(key);
  }
  auto find = [&](PredictionFilterKind f, int order, double snr, double h) -> const Setting* {
    for (const auto& s : settings) {
      if (s.filter == f && s.order == order && s.snr_db == snr && s.horizon == h) return &s;
    }
    return nullptr;
  };
  for (const auto& [filter, order] : blocks) {
    out << "filter " << ToString(filter);
    if (filter == PredictionFilterKind::kLinear) {
      out << ", order " << order << ", ";
      if (base.optimize_window)
        out << "window optimized (golden search over [" << order + 1 << ", " << base.window_max - 1
            << "])";
      else
        out << "fixed window WF = " << base.window;
    }
    if (filter != PredictionFilterKind::kNone) out << ", PCA window WP = " << base.pca_window;
    out << "\nmean over markers: RMS (mm) / nRMS (%) of the 3D position error\n";
    out << Pad("SNR \\ horizon", 14);
    for (double h : horizons) out << " |" << Pad(Str(Fixed(h, 3), " s"), cell);
    out << "\n" << std::string(14 + horizons.size() * (cell + 2), '-') << "\n";
    for (double snr : snrs) {
      out << Pad(SnrLabel(snr), 14);
      for (double h : horizons) {
        const Setting* s = find(filter, order, snr, h);
        out << " |"
            << Pad(Str(Fixed(kMm * MeanOver(*s, &MarkerEvaluation::rms), 3), " / ",
                       Fixed(kPercent * MeanOver(*s, &MarkerEvaluation::nrms), 1)),
                   cell);
      }
      out << "\n";
    }
    out << "per marker nRMS (%)";
    if (filter == PredictionFilterKind::kLinear && base.optimize_window) out << " [chosen WF]";
    out << "\n";
    for (double snr : snrs) {
      const Setting* first = find(filter, order, snr, horizons.front());
      for (size_t m = 0; m < first->evaluation.markers.size(); ++m) {
        out << Pad(Str(SnrLabel(snr), " m", m), 14);
        for (double h : horizons) {
          const MarkerEvaluation& e = find(filter, order, snr, h)->evaluation.markers[m];
          std::string text = Fixed(kPercent * e.nrms, 1);
          if (filter == PredictionFilterKind::kLinear && base.optimize_window)
            text += Str(" [", e.window, "]");
          out << " |" << Pad(text, cell);
        }
        out << "\n";
      }
    }
    out << "\n";
  }
  return out.str();
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
      "DIR/predict_eval.json, DIR/table.txt and DIR/marker<m>.png (first setting).");
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
      .Flag("no-plots", "skip the PNG plots");
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;

  const std::vector<double> horizons = ParseHorizons(cli.GetString("horizon"));
  const std::vector<int> orders = ParseOrders(cli.GetString("order"));
  const std::vector<double> snrs = ParseSnrs(cli.GetString("snr-db"));
  const std::vector<PredictionFilterKind> filters = ParseFilters(cli.GetString("filter"));
  const long seed = cli.GetInt("seed");
  if (seed < 0) throw InputError(Str("--seed must be >= 0, got ", seed));

  PredictionConfig base;
  base.optimize_window = cli.GetFlag("optimize-window");
  base.window = ParseCount(cli, "window", 1);
  base.window_max = ParseCount(cli, "window-max", 1);
  base.pca_window = ParseCount(cli, "pca-window", 1);
  base.pca_update_interval = ParseCount(cli, "pca-interval", 0);
  base.search_interval = ParseCount(cli, "search-interval", 0);
  base.search_lead = ParseCount(cli, "search-lead", 1);
  base.kalman_harmonics = ParseCount(cli, "kalman-harmonics", 1);
  // validate every configuration before the (longer) evaluation
  for (PredictionFilterKind f : filters) {
    for (int order : orders) {
      PredictionConfig c = base;
      c.filter = f;
      c.order = order;
      c.Validate();
    }
  }

  const std::string input = cli.GetString("markers");
  const MarkerStream clean = ReadMarkerCsv(input);
  if (clean.frames.size() < 3)
    throw InputError(Str(input, ": needs at least 3 frames, got ", clean.frames.size()));
  const std::filesystem::path out_dir = cli.GetString("out");
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir))
    throw InputError(
        Str("--out: cannot create directory '", out_dir.string(), "': ", ec.message()));

  std::vector<Setting> settings;
  for (double snr : snrs) {
    // one noise realization per SNR: the same seed scales the same draws
    const MarkerStream measured = AddWhiteNoise(clean, snr, static_cast<uint64_t>(seed));
    std::vector<double> measured_snr(clean.num_markers, std::numeric_limits<double>::infinity());
    if (!std::isinf(snr)) {
      for (int m = 0; m < clean.num_markers; ++m)
        measured_snr[m] = MeasureSnrDb(clean, measured, m);
    }
    for (PredictionFilterKind f : filters) {
      // orders only matter for the polynomial filter
      const std::vector<int> filter_orders =
          f == PredictionFilterKind::kLinear ? orders : std::vector<int>{0};
      for (int order : filter_orders) {
        for (double h : horizons) {
          PredictionConfig c = base;
          c.filter = f;
          c.order = order > 0 ? order : base.order;
          Setting s{f, order, snr, h, EvaluatePrediction(measured, clean, c, h), measured_snr};
          settings.push_back(std::move(s));
        }
      }
    }
  }

  // JSON report
  nlohmann::json report;
  report["input"] = input;
  report["num_markers"] = clean.num_markers;
  report["num_frames"] = clean.frames.size();
  report["duration_s"] = clean.frames.back().stamp.sim_time - clean.frames.front().stamp.sim_time;
  report["seed"] = seed;
  report["error_definition"] =
      "3D Euclidean position error vs the noise-free input, resampled on a uniform grid "
      "(step = mean frame interval) from the first prediction target time to the last frame";
  report["jitter_definition"] =
      "RMS norm of the second difference of the resampled prediction (at the grid step)";
  report["config"] = {
      {"pca_window", base.pca_window},           {"pca_update_interval", base.pca_update_interval},
      {"optimize_window", base.optimize_window}, {"window", base.window},
      {"window_max", base.window_max},           {"search_interval", base.search_interval},
      {"search_lead", base.search_lead},         {"kalman_harmonics", base.kalman_harmonics}};
  nlohmann::json list = nlohmann::json::array();
  for (const auto& s : settings) {
    nlohmann::json j;
    j["filter"] = ToString(s.filter);
    j["order"] =
        s.filter == PredictionFilterKind::kLinear ? nlohmann::json(s.order) : nlohmann::json();
    j["snr_db"] = std::isinf(s.snr_db) ? nlohmann::json() : nlohmann::json(s.snr_db);
    j["horizon_s"] = s.horizon;
    j["first_ready_frame"] = s.evaluation.first_ready_frame;
    j["grid_samples"] = s.evaluation.t_grid.size();
    j["mean"] = {{"rms_mm", kMm * MeanOver(s, &MarkerEvaluation::rms)},
                 {"rms_delayed_mm", kMm * MeanOver(s, &MarkerEvaluation::rms_delayed)},
                 {"nrms_percent", kPercent * MeanOver(s, &MarkerEvaluation::nrms)},
                 {"jitter_mm", kMm * MeanOver(s, &MarkerEvaluation::jitter)}};
    nlohmann::json markers = nlohmann::json::array();
    for (size_t m = 0; m < s.evaluation.markers.size(); ++m) {
      const MarkerEvaluation& e = s.evaluation.markers[m];
      markers.push_back({{"marker", m},
                         {"rms_mm", kMm * e.rms},
                         {"rms_delayed_mm", kMm * e.rms_delayed},
                         {"nrms_percent", kPercent * e.nrms},
                         {"jitter_mm", kMm * e.jitter},
                         {"window", e.window},
                         {"measured_snr_db", std::isinf(s.measured_snr_db[m])
                                                 ? nlohmann::json()
                                                 : nlohmann::json(s.measured_snr_db[m])}});
    }
    j["markers"] = markers;
    list.push_back(j);
  }
  report["settings"] = list;
  const std::string json_path = (out_dir / "predict_eval.json").string();
  std::ofstream json_file(json_path);
  if (!json_file) throw InputError(Str("cannot write '", json_path, "'"));
  json_file << report.dump(2) << "\n";

  // text table, figs. 5.3-5.6 style: rows SNR, columns horizon
  const std::string table = MakeTable(settings, snrs, horizons, base);
  std::cout << table;
  const std::string table_path = (out_dir / "table.txt").string();
  std::ofstream table_file(table_path);
  if (!table_file) throw InputError(Str("cannot write '", table_path, "'"));
  table_file << table;

  if (!cli.GetFlag("no-plots")) {
    for (int m = 0; m < clean.num_markers; ++m)
      WriteMarkerPlot((out_dir / Str("marker", m, ".png")).string(), settings.front(), m);
  }
  std::cout << "predict-eval: " << settings.size() << " settings, wrote " << json_path << "\n";
  return 0;
}

}  // namespace nsim
