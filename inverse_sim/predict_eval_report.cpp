#include "inverse_sim/predict_eval_report.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "common/core/error.h"
#include "common/prediction/pca_buffer.h"

extern char** environ;

namespace nsim {
namespace {

constexpr double kMm = 1e3;       // m -> mm
constexpr double kPercent = 100;  // ratio -> %

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

double MeanOver(const PredictEvalSetting& s, double MarkerEvaluation::*field) {
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

// the metrics of one setting, mean and per marker
nlohmann::json SettingJson(const PredictEvalSetting& s) {
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
  return j;
}

// One block of the table: the settings of one (filter, order), rows SNR, columns horizon.
struct TableBlock {
  static constexpr size_t kLabel = 14, kCell = 18;  // column widths

  const std::vector<PredictEvalSetting>& settings;
  const std::vector<double>& snrs;
  const std::vector<double>& horizons;
  const PredictionConfig& base;

  void Write(PredictionFilterKind filter, int order, std::ostream& out) const {
    WriteTitle(filter, order, out);
    WriteMeans(filter, order, out);
    WritePerMarker(filter, order, out);
    out << "\n";
  }

  const PredictEvalSetting& Find(PredictionFilterKind f, int order, double snr, double h) const {
    for (const auto& s : settings) {
      if (s.filter == f && s.order == order && s.snr_db == snr && s.horizon == h) return s;
    }
    throw std::logic_error("predict-eval table: a combination was not evaluated");
  }

  // the filter and its settings
  void WriteTitle(PredictionFilterKind filter, int order, std::ostream& out) const {
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
    out << "\n";
  }

  // RMS / nRMS, mean over the markers
  void WriteMeans(PredictionFilterKind filter, int order, std::ostream& out) const {
    out << "mean over markers: RMS (mm) / nRMS (%) of the 3D position error\n";
    out << Pad("SNR \\ horizon", kLabel);
    for (double h : horizons) out << " |" << Pad(Str(Fixed(h, 3), " s"), kCell);
    out << "\n" << std::string(kLabel + horizons.size() * (kCell + 2), '-') << "\n";
    for (double snr : snrs) {
      out << Pad(SnrLabel(snr), kLabel);
      for (double h : horizons) {
        const PredictEvalSetting& s = Find(filter, order, snr, h);
        out << " |"
            << Pad(Str(Fixed(kMm * MeanOver(s, &MarkerEvaluation::rms), 3), " / ",
                       Fixed(kPercent * MeanOver(s, &MarkerEvaluation::nrms), 1)),
                   kCell);
      }
      out << "\n";
    }
  }

  // nRMS of each marker, with the chosen LF window when it was optimized
  void WritePerMarker(PredictionFilterKind filter, int order, std::ostream& out) const {
    const bool show_window = filter == PredictionFilterKind::kLinear && base.optimize_window;
    out << "per marker nRMS (%)";
    if (show_window) out << " [chosen WF]";
    out << "\n";
    for (double snr : snrs) {
      const PredictEvalSetting& first = Find(filter, order, snr, horizons.front());
      for (size_t m = 0; m < first.evaluation.markers.size(); ++m) {
        out << Pad(Str(SnrLabel(snr), " m", m), kLabel);
        for (double h : horizons) {
          const MarkerEvaluation& e = Find(filter, order, snr, h).evaluation.markers[m];
          std::string text = Fixed(kPercent * e.nrms, 1);
          if (show_window) text += Str(" [", e.window, "]");
          out << " |" << Pad(text, kCell);
        }
        out << "\n";
      }
    }
  }
};

}  // namespace

void WritePredictEvalJson(const std::string& path, const std::string& input,
                          const MarkerStream& clean, long seed, const PredictionConfig& base,
                          const std::vector<PredictEvalSetting>& settings) {
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
  for (const auto& s : settings) list.push_back(SettingJson(s));
  report["settings"] = list;
  report["plot_setting"] = 0;  // the series of DIR/marker<m>.csv
  WriteTextFile(path, report.dump(2) + "\n");
}

std::string PredictEvalTable(const std::vector<PredictEvalSetting>& settings,
                             const std::vector<double>& snrs, const std::vector<double>& horizons,
                             const PredictionConfig& base) {
  // one block per (filter, order), in the order they were evaluated
  std::vector<std::pair<PredictionFilterKind, int>> blocks;
  for (const auto& s : settings) {
    const std::pair<PredictionFilterKind, int> key{s.filter, s.order};
    bool seen = false;
    for (const auto& b : blocks) seen = seen || b == key;
    if (!seen) blocks.push_back(key);
  }
  const TableBlock block{settings, snrs, horizons, base};
  std::ostringstream out;
  for (const auto& [filter, order] : blocks) block.Write(filter, order, out);
  return out.str();
}

void WriteMarkerSeriesCsv(const std::string& path, const PredictEvalSetting& s, int m) {
  const MarkerEvaluation& e = s.evaluation.markers[m];
  const std::vector<double>& t = s.evaluation.t_grid;
  PcaBuffer buffer(static_cast<int>(e.reference.rows()));
  for (long i = 0; i < e.reference.rows(); ++i) buffer.Push(t[i], e.reference.row(i).transpose());
  PrincipalAxes axes;
  buffer.CalcPrincipalAxes(&axes);
  const std::vector<double> delayed = AlongAxis(e.delayed, axes);
  const std::vector<double> reference = AlongAxis(e.reference, axes);
  const std::vector<double> predicted = AlongAxis(e.predicted, axes);

  std::ostringstream out;
  out << "t,delayed_pc_mm,reference_pc_mm,predicted_pc_mm,error_predicted_mm,error_delayed_mm\n";
  char row[256];
  for (size_t i = 0; i < t.size(); ++i) {
    const double err_pred = kMm * (e.predicted.row(i) - e.reference.row(i)).norm();
    const double err_none = kMm * (e.delayed.row(i) - e.reference.row(i)).norm();
    std::snprintf(row, sizeof(row), "%.10g,%.10g,%.10g,%.10g,%.10g,%.10g\n", t[i], delayed[i],
                  reference[i], predicted[i], err_pred, err_none);
    out << row;
  }
  WriteTextFile(path, out.str());
}

bool DrawPredictEvalFigures(const std::string& script, const std::string& dir, std::string* why) {
  const char* python = "/usr/bin/python3";
  if (access(python, X_OK) != 0) {
    *why = Str(python, " is missing (apt-get install python3-matplotlib)");
    return false;
  }
  if (access(script.c_str(), R_OK) != 0) {
    *why = Str("the plot script '", script, "' is missing");
    return false;
  }
  std::vector<std::string> args = {python, script, "predict-eval", dir};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, python, nullptr, nullptr, argv.data(), environ) != 0) {
    *why = Str("cannot start ", python);
    return false;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return true;
  // plot_results.py exits with 3 when matplotlib is missing
  *why = WIFEXITED(status) && WEXITSTATUS(status) == 3
             ? Str(python, " has no matplotlib (apt-get install python3-matplotlib)")
             : Str(script, " failed (", WIFEXITED(status) ? "exit code " : "signal ",
                   WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status), ")");
  return false;
}

void WriteTextFile(const std::string& path, const std::string& text) {
  std::ofstream file(path);
  if (!file) throw InputError(Str("cannot write '", path, "'"));
  file << text;
}

}  // namespace nsim
