#include "inverse_sim/predict_eval.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/breathing/breathing.h"
#include "common/breathing/marker_motion.h"
#include "common/core/error.h"
#include "common/markers/marker_csv.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;

int RunCommand(std::vector<std::string> args) {
  args.insert(args.begin(), "predict-eval");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return RunPredictEval(static_cast<int>(argv.size()), argv.data());
}

fs::path TestDir() {
  const fs::path dir = fs::temp_directory_path() / "nsim_predict_eval_test";
  fs::create_directories(dir);
  return dir;
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
  for (int m = 0; m < 3; ++m) {
    const cv::Mat png = cv::imread((out / ("marker" + std::to_string(m) + ".png")).string());
    ASSERT_FALSE(png.empty());
    EXPECT_EQ(png.cols, 1000);
    EXPECT_EQ(png.rows, 800);  // two stacked 400 px panels
  }
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
