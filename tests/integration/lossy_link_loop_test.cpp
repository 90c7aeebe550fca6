// The lockstep closed loop with a lossy link (direct_sim run --in-process --loss PCT), on the
// coarse scenario configs/scenarios/liver_test_coarse.yaml: 20 % of the frames and of the
// targets lost, the insertion still reaches the target; the counts are the binomial share and
// agree between the two sides (the controller misses exactly the frames the link lost); the
// same seed gives the same run byte for byte, also through scripts/experiment_run.sh (which
// passes --loss on); the next seed loses other frames; --loss 0 is the run without it; a loss
// outside [0, 100] or without --in-process is refused with a message naming it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/integration/child_process.h"
#include "tests/integration/closed_loop_util.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::Cat;
using testing::ChildProcess;
using testing::kBin;
using testing::kSource;
using testing::ReadText;
using testing::TempDir;
using testing::WriteScenario;

// the reach tolerance of closed_loop_test (the tip starts 65 mm from the target)
constexpr double kReachToleranceMm = 2.0;

// direct_sim run --in-process into DIR/NAME/direct (controller DIR/NAME/inverse); exit code
int RunInProcess(const fs::path& dir, const std::string& name, const fs::path& scenario,
                 const std::vector<std::string>& extra) {
  ChildProcess p(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                      (dir / name / "direct").string(), "--in-process", "--prediction", "off",
                      "--no-video", "--quiet"},
                     extra),
                 (dir / (name + ".log")).string());
  const int code = p.Wait(120.0);
  EXPECT_EQ(code, 0) << p.Output();
  return code;
}

json Summary(const fs::path& dir, const std::string& name, const std::string& side) {
  return json::parse(ReadText(dir / name / side / "summary.json"));
}

std::string Timeseries(const fs::path& dir, const std::string& name) {
  return ReadText(dir / name / "direct/timeseries.csv");
}

TEST(LossyLink, TheLoopReachesTheTargetAndTheSameSeedGivesTheSameRun) {
  const fs::path dir = TempDir("lossy_link");
  const fs::path scenario = WriteScenario(dir, {});
  const std::vector<std::string> run = {"--duration", "11", "--seed", "3", "--young-modulus",
                                        "5500", "--loss", "20"};
  ASSERT_EQ(RunInProcess(dir, "a", scenario, run), 0);
  const json d = Summary(dir, "a", "direct"), i = Summary(dir, "a", "inverse");
  EXPECT_EQ(d["exit"], "completed");
  EXPECT_LT(d["final_tip_to_target_distance_mm"].get<double>(), kReachToleranceMm) << d.dump();
  // 551 frames (550 steps and the final one, which the link delivers like a reliable stream's
  // last sample), 20 % lost: 110 +- 9.4; 5 standard deviations
  const double frames_lost = d["link_loss"]["frames_lost"].get<double>();
  const double targets_lost = d["link_loss"]["targets_lost"].get<double>();
  EXPECT_EQ(d["link_loss"]["percent"], 20.0);
  EXPECT_NEAR(frames_lost, 0.2 * 550, 5 * std::sqrt(550 * 0.2 * 0.8));
  // the controller saw every other frame and missed exactly those
  EXPECT_EQ(i["frames_missing"].get<double>(), frames_lost);
  EXPECT_EQ(i["frames_received"].get<double>(), 551 - frames_lost);
  const double answered = i["frames_answered"].get<double>();
  EXPECT_NEAR(targets_lost, 0.2 * answered, 5 * std::sqrt(answered * 0.2 * 0.8));
  // each target the link lost is one the robot never carried out (a newer one replaces it)
  EXPECT_LE(d["targets"]["applied"].get<double>(), answered - targets_lost);

  // the same run through scripts/experiment_run.sh (seed 3, E 5500 Pa, --loss 20): byte for byte
  ChildProcess script({kSource + "/scripts/experiment_run.sh", "run", "--out",
                       (dir / "script").string(), "--bin", kBin, "--loss", "20", "--duration", "11",
                       "pred_off", "0", "3", "5500", scenario.string(), "--prediction off"},
                      (dir / "script.log").string());
  ASSERT_EQ(script.Wait(120.0), 0) << script.Output();
  EXPECT_TRUE(Timeseries(dir, "a") == ReadText(dir / "script/pred_off/run_0/direct/timeseries.csv"))
      << "the same seed and loss gave another run";

  // the next seed loses other frames (and breathes otherwise)
  std::vector<std::string> next = run;
  next[3] = "4";
  ASSERT_EQ(RunInProcess(dir, "b", scenario, next), 0);
  EXPECT_NE(Summary(dir, "b", "direct")["link_loss"], d["link_loss"]);
}

TEST(LossyLink, NoLossIsTheRunWithoutTheOption) {
  const fs::path dir = TempDir("lossy_link_zero");
  const fs::path scenario = WriteScenario(dir, {});
  ASSERT_EQ(RunInProcess(dir, "plain", scenario, {"--duration", "3"}), 0);
  ASSERT_EQ(RunInProcess(dir, "zero", scenario, {"--duration", "3", "--loss", "0"}), 0);
  EXPECT_TRUE(Timeseries(dir, "plain") == Timeseries(dir, "zero"));
  const json d = Summary(dir, "zero", "direct");
  EXPECT_EQ(d["link_loss"]["frames_lost"], 0);
  EXPECT_EQ(d["link_loss"]["targets_lost"], 0);
  EXPECT_EQ(d["targets"]["lockstep_timeouts"], 0);
}

TEST(LossyLink, BadLossesAreRefusedByName) {
  const fs::path dir = TempDir("lossy_link_bad");
  const fs::path scenario = WriteScenario(dir, {});
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  for (const Case& c : std::vector<Case>{
           {{"--in-process", "--loss", "120"}, "--loss must be in [0, 100] (percent), got 120"},
           {{"--in-process", "--loss", "-1"}, "--loss must be in [0, 100] (percent), got -1"},
           {{"--loss", "5"}, "--loss needs --in-process"}}) {
    ChildProcess p(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                        (dir / "out").string(), "--duration", "1", "--no-video", "--quiet"},
                       c.args),
                   (dir / "bad.log").string());
    EXPECT_EQ(p.Wait(30.0), 2) << p.Output();
    EXPECT_NE(p.Output().find(c.message), std::string::npos) << p.Output();
  }
}

}  // namespace
}  // namespace nsim
