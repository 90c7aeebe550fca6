#include "inverse_sim/predict_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/breathing/breathing.h"
#include "common/breathing/marker_motion.h"
#include "common/core/error.h"
#include "common/markers/marker_csv.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;

int RunCommand(std::vector<std::string> args) {
  args.insert(args.begin(), "predict-eval");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return RunPredictEval(static_cast<int>(argv.size()), argv.data());
}

// the running test's own temporary folder (removed when the test passes)
fs::path TestDir() { return testing::TestTempDir(); }

// the figures are drawn by scripts/plot_results.py when Debian's python3 has matplotlib
bool HavePythonMatplotlib() {
  return std::system("/usr/bin/python3 -c 'import matplotlib' > /dev/null 2>&1") == 0;
}

// width and height of a PNG file from its IHDR chunk; {0, 0} when it is not a PNG
std::pair<int, int> PngSize(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[24] = {};
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!in || !std::equal(signature, signature + 8, head)) return {0, 0};
  auto be32 = [&](int i) {
    return (head[i] << 24) | (head[i + 1] << 16) | (head[i + 2] << 8) | head[i + 3];
  };
  return {be32(16), be32(20)};
}

// the rows of a plot-series CSV: its header, then the number of data rows, each with 6 values
std::pair<std::string, int> ReadSeries(const fs::path& path) {
  std::ifstream in(path);
  std::string header, line;
  std::getline(in, header);
  int rows = 0;
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::string field;
    int count = 0;
    while (std::getline(fields, field, ',')) {
      EXPECT_TRUE(std::isfinite(std::stod(field))) << path << ": " << line;
      ++count;
    }
    EXPECT_EQ(count, 6) << path << ": " << line;
    ++rows;
  }
  return {header, rows};
}

// a small generated stream: 20 s, 30 Hz, 3 markers
std::string WriteStream() {
  BreathingConfig b;
  b.horizon = 30;
  MarkerMotionConfig m;
  m.duration = 20;
  m.num_markers = 3;
  const std::string path = (TestDir() / "stream.csv").string();
  WriteMarkerCsv(path, MakeBreathingMarkerStream(BreathingModel(b), m));
  return path;
}

TEST(PredictEval, RunsOnAGeneratedStreamAndWritesJsonTableAndPlots) {
  const std::string stream = WriteStream();
  const fs::path out = TestDir() / "out";
  fs::remove_all(out);
  ASSERT_EQ(
      RunCommand({"--markers", stream, "--out", out.string(), "--horizon", "0.1,0.3", "--order",
                  "1,2", "--snr-db", "60,20", "--filter", "lf,none,kalman", "--optimize-window",
                  "--pca-window", "150", "--window-max", "30", "--seed", "5"}),
      0);
  std::ifstream in(out / "predict_eval.json");
  ASSERT_TRUE(in.good());
  const nlohmann::json report = nlohmann::json::parse(in);
  // 2 SNR x 2 horizons x (2 LF orders + none + kalman)
  ASSERT_EQ(report.at("settings").size(), 16u);
  for (const auto& s : report.at("settings")) {
    ASSERT_EQ(s.at("markers").size(), 3u);
    for (const auto& m : s.at("markers")) {
      for (const char* key : {"rms_mm", "nrms_percent", "jitter_mm", "window"})
        EXPECT_TRUE(m.contains(key));
      if (s.at("filter") == "none") {
        EXPECT_DOUBLE_EQ(m.at("nrms_percent").get<double>(), 100.0);
      }
      if (s.at("filter") == "lf") {
        EXPECT_GE(m.at("window").get<int>(), s.at("order").get<int>() + 1);
        EXPECT_LE(m.at("window").get<int>(), 29);
      }
    }
    EXPECT_TRUE(s.at("mean").contains("nrms_percent"));
  }
  EXPECT_TRUE(fs::exists(out / "table.txt"));
  EXPECT_EQ(report.at("plot_setting"), 0);
  const size_t grid = report.at("settings").at(0).at("grid_samples").get<size_t>();
  const bool figures = HavePythonMatplotlib();
  for (int m = 0; m < 3; ++m) {
    const std::string name = "marker" + std::to_string(m);
    const auto [header, rows] = ReadSeries(out / (name + ".csv"));
    EXPECT_EQ(
        header,
        "t,delayed_pc_mm,reference_pc_mm,predicted_pc_mm,error_predicted_mm,error_delayed_mm");
    EXPECT_EQ(static_cast<size_t>(rows), grid);
    if (!figures) continue;  // predict-eval says the figures were not made, and succeeds
    // scripts/plot_results.py predict-eval: 10 x 8 in at 100 dpi, two stacked panels
    EXPECT_EQ(PngSize(out / (name + ".png")), std::make_pair(1000, 800)) << name;
  }
  if (!figures) std::cout << "no /usr/bin/python3 with matplotlib: PNGs not checked\n";
}

TEST(PredictEval, WithoutThePlotScriptStillSucceedsAndWritesTheSeries) {
  const std::string stream = WriteStream();
  const fs::path out = TestDir() / "no_script";
  fs::remove_all(out);
  ASSERT_EQ(RunCommand({"--markers", stream, "--out", out.string(), "--pca-window", "150",
                        "--window-max", "30", "--plot-script", "/nonexistent/plot_results.py"}),
            0);
  EXPECT_TRUE(fs::exists(out / "marker0.csv"));
  EXPECT_FALSE(fs::exists(out / "marker0.png"));

  const fs::path none = TestDir() / "no_plots";
  fs::remove_all(none);
  ASSERT_EQ(RunCommand({"--markers", stream, "--out", none.string(), "--pca-window", "150",
                        "--window-max", "30", "--no-plots"}),
            0);
  EXPECT_TRUE(fs::exists(none / "predict_eval.json"));
  EXPECT_FALSE(fs::exists(none / "marker0.csv"));
  EXPECT_FALSE(fs::exists(none / "marker0.png"));
}

TEST(PredictEval, HelpReturnsZero) { EXPECT_EQ(RunCommand({"--help"}), 0); }

TEST(PredictEval, BadInputThrowsInputErrorNamingWhatWasWrong) {
  const std::string stream = WriteStream();
  const std::string out = (TestDir() / "bad").string();
  auto message = [&](std::vector<std::string> extra) -> std::string {
    std::vector<std::string> args = {"--markers",    stream, "--out",        out,
                                     "--pca-window", "150",  "--window-max", "30",
                                     "--no-plots"};
    args.insert(args.end(), extra.begin(), extra.end());
    try {
      RunCommand(args);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message({"--filter", "lf,wlms"}),
            "--filter: prediction.filter must be one of none, lf, kalman; got 'wlms'");
  EXPECT_EQ(message({"--horizon", "0.1,-0.2"}), "--horizon: values must be >= 0 (s), got -0.2");
  EXPECT_EQ(message({"--order", "2", "--window", "2"}),
            "prediction.window must be >= order+1 (3), got 2");
  EXPECT_EQ(message({"--snr-db", "40,abc"}), "--snr-db: expected a finite number, got 'abc'");
  EXPECT_NE(message({"--pca-window", "700"}).find("is too short for filter lf"), std::string::npos);

  // a NaN and a non-increasing time in the input file
  const std::string nan_csv = (TestDir() / "nan.csv").string();
  std::ofstream(nan_csv) << "t,m0_x,m0_y,m0_z\n0,0,0,0\n0.1,0,nan,0\n";
  EXPECT_NE(message({"--markers", nan_csv}).find("nan.csv:3"), std::string::npos);
  const std::string back_csv = (TestDir() / "back.csv").string();
  std::ofstream(back_csv) << "t,m0_x,m0_y,m0_z\n0,0,0,0\n0.1,0,1,0\n0.1,0,2,0\n";
  EXPECT_NE(message({"--markers", back_csv}).find("back.csv:4"), std::string::npos);
}

}  // namespace
}  // namespace nsim
