// direct_sim run as a process: a --no-controller insertion (no peer), and a run against a
// scripted controller in this process that sends good, too fast, out-of-order, stale, unknown
// and NaN targets and then leaves.
#include <gtest/gtest.h>

#include <chrono>
#include <deque>
#include <thread>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "common/core/clock.h"
#include "messages/transport.h"
#include "tests/integration/child_process.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::Cat;
using testing::ChildProcess;
using testing::ReadText;
using testing::TempDir;

const std::string kBin = NSIM_BIN_DIR;
const std::string kSource = NSIM_SOURCE_DIR;
const std::string kDdsConfig = kSource + "/configs/dds/local.xml";

// the default scenario with the coarse liver (absolute mesh paths) and the given edits
fs::path WriteScenario(const fs::path& dir,
                       const std::vector<std::pair<std::string, std::string>>& edits) {
  auto all = edits;
  all.insert(all.begin(), {"liver_2660.msh", "liver_700.msh"});
  return testing::WriteEditedScenario(dir, "scenario.yaml", "liver_breathing.yaml", all);
}

TEST(DirectRun, NoControllerInsertionPuncturesSkinAndLiver) {
  const fs::path dir = TempDir("direct_run");
  // the default scenario asks for refreshes adopted when ready (the edit to itself fails the
  // test if it stops asking); a lockstep run adopts them on schedule
  const fs::path scenario = WriteScenario(
      dir, {{"speed: 0.01", "speed: 0.02"},
            {"refactor_adoption: when_ready", "refactor_adoption: when_ready"}});
  const std::string partition = "direct_run_" + std::to_string(getpid());
  // lockstep without a controller: nothing to wait for, runs as fast as it can
  ChildProcess run(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                        (dir / "out").string(), "--no-controller", "--duration", "2", "--mode",
                        "lockstep", "--vtk-every", "50", "--quiet"},
                       testing::DdsArgs(41, partition)),
                   (dir / "run.log").string());
  const int code = run.Wait(60.0);
  ASSERT_EQ(code, 0) << run.Output();

  const json s = json::parse(ReadText(dir / "out/summary.json"));
  EXPECT_EQ(s["exit"], "completed");
  EXPECT_EQ(s["steps"], 100);
  EXPECT_EQ(s["controller"], false);
  EXPECT_TRUE(s["punctured"]["skin"]["punctured"].get<bool>());
  EXPECT_TRUE(s["punctured"]["liver"]["punctured"].get<bool>());
  EXPECT_LT(s["punctured"]["skin"]["time_s"].get<double>(),
            s["punctured"]["liver"]["time_s"].get<double>());
  EXPECT_GT(s["step_time_ms"]["median"].get<double>(), 0.0);
  EXPECT_GT(s["rate_hz"].get<double>(), 0.0);
  EXPECT_LT(s["final_tip_to_target_distance_mm"].get<double>(), 50.0);  // 65 mm at the start
  EXPECT_EQ(s["targets"]["received"], 0);
  EXPECT_LT(s["max_rib_penetration_mm"].get<double>(), 1e-5);
  EXPECT_TRUE(s["min_joint_limit_margin_rad"].is_null());  // the Cartesian robot has no joints
  EXPECT_EQ(s["outputs"]["vtk_snapshots"], 2);
  EXPECT_EQ(s["settings"]["liver_nodes"], 685);
  EXPECT_TRUE(fs::exists(dir / "out/vtk/liver_000050.vtk"));
  EXPECT_TRUE(fs::exists(dir / "out/view.png"));
  // timeseries: header + frames 0..100
  std::ifstream csv(dir / "out/timeseries.csv");
  std::string line;
  int lines = 0;
  while (std::getline(csv, line)) ++lines;
  EXPECT_EQ(lines, 102);
  // the liver's solver: the summary's counts are those of step_times.csv's columns
  const json& liver = s["liver_solver"];
  EXPECT_EQ(liver["refactor_adoption"], "scheduled");
  EXPECT_EQ(liver["in_step_factorizations"], 0);
  std::ifstream steps(dir / "out/step_times.csv");
  std::getline(steps, line);
  EXPECT_EQ(line, "step,t,step_ms,holding,liver_pcg_iterations,liver_factor_adopted,"
                  "liver_adoption_waited");
  double iterations = 0;
  int rows = 0, adopted = 0, waited = 0;
  while (std::getline(steps, line)) {
    std::stringstream row(line);
    std::vector<std::string> cells;
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 7u) << line;
    iterations += std::stod(cells[4]);
    adopted += std::stoi(cells[5]);
    waited += std::stoi(cells[6]);
    ++rows;
  }
  EXPECT_EQ(rows, 100);
  EXPECT_GT(iterations, 0.0);
  EXPECT_NEAR(liver["pcg_iterations_per_step"].get<double>(), iterations / rows, 1e-12);
  EXPECT_EQ(liver["factors_adopted"], adopted);
  EXPECT_EQ(liver["adoptions_that_waited"], waited);
  if (adopted > 0) EXPECT_EQ(liver["mean_adoption_lag_steps"], 3.0);  // scheduled: the delay
}

TEST(DirectRun, BadScenarioExitsWithTwoAndNamesTheKey) {
  const fs::path dir = TempDir("direct_run_bad");
  const fs::path scenario =
      WriteScenario(dir, {{"young_modulus: 5500      #", "young_modulus: abc      #"}});
  ChildProcess run({kBin + "/direct_sim", "run", "--config", scenario.string(), "--no-controller"},
                   (dir / "run.log").string());
  EXPECT_EQ(run.Wait(30.0), 2);
  EXPECT_NE(run.Output().find("patient.liver.young_modulus: expected a number, got 'abc'"),
            std::string::npos)
      << run.Output();
}

// a state outside the watchdog's bounds ends the run as a failure that says why, never as
// "completed": the breathing moves the liver ~12 mm, beyond a 2 mm bound
TEST(DirectRun, AnImplausibleStateStopsTheRunWithTheReason) {
  const fs::path dir = TempDir("direct_run_watchdog");
  const fs::path scenario = WriteScenario(
      dir, {{"max_displacement: 0.1 ", "max_displacement: 0.002 "}});
  ChildProcess run(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                        (dir / "out").string(), "--no-controller", "--duration", "5", "--mode",
                        "lockstep", "--quiet"},
                       testing::DdsArgs(41, "direct_run_wd_" + std::to_string(getpid()))),
                   (dir / "run.log").string());
  EXPECT_EQ(run.Wait(60.0), 1);
  EXPECT_NE(run.Output().find("the state is not plausible"), std::string::npos) << run.Output();
  const json s = json::parse(ReadText(dir / "out/summary.json"));
  EXPECT_EQ(s["exit"], "implausible_state");
  EXPECT_NE(s["fault"].get<std::string>().find("watchdog.max_displacement 2 mm"),
            std::string::npos)
      << s["fault"];
  EXPECT_LT(s["steps"].get<int>(), 250);
}

// a controller in this process: answers the frames with a script of good and bad targets
TEST(DirectRun, SafetyGateCountsBadTargetsAndNoticesTheControllerLeaving) {
  const fs::path dir = TempDir("direct_run_safety");
  const fs::path scenario = WriteScenario(dir, {});
  const std::string partition = "direct_safety_" + std::to_string(getpid());
  transport::TransportConfig tc;
  tc.domain_id = 42;
  tc.partition = partition;
  tc.config_file = kDdsConfig;
  transport::Participant participant(tc);
  transport::Reader<SensorFrame> frames(participant, transport::Qos::kLossless);
  auto targets =
      std::make_unique<transport::Writer<RobotTarget>>(participant, transport::Qos::kTarget);

  ChildProcess run(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                        (dir / "out").string(), "--duration", "4", "--no-video", "--quiet"},
                       testing::DdsArgs(42, partition)),
                   (dir / "run.log").string());
  std::deque<SensorFrame> queue;  // frames taken, not yet answered
  std::vector<SensorFrame> got;
  auto take = [&] {
    got.clear();
    frames.Take(got);
    queue.insert(queue.end(), got.begin(), got.end());
  };
  uint64_t newest = 0;  // the newest frame seen: direct_sim has stepped that far
  const double end = MonotonicSeconds() + 60.0;
  while (targets && MonotonicSeconds() < end) {
    if (queue.empty()) frames.Wait(0.05);
    take();
    while (!queue.empty() && targets) {
      const SensorFrame f = queue.front();
      queue.pop_front();
      const uint64_t k = f.stamp.seq;
      newest = std::max(newest, k);
      RobotTarget t;
      t.answers_seq = k;
      t.X_WE = f.X_WE;  // hold where the frame says the robot is
      if (k == 10) t.X_WE.translation().x() = std::nan("");             // dropped by the transport
      if (k == 12) t.X_WE.translation() += Eigen::Vector3d(0.2, 0, 0);  // too fast: clamped
      if (k == 16) t.answers_seq = 11;                                  // out of order
      if (k == 17) t.answers_seq = 100000;                              // never published
      if (k >= 18 && k < 45) continue;                                  // silent: the robot holds
      if (k == 45) t.answers_seq = 18;                                  // 27 frames old: stale
      if (k >= 50) {
        targets.reset();  // the controller leaves
        break;
      }
      targets->Write(t);
      // targets are keep-last 1: before the next target can replace a scripted bad one, wait
      // until direct_sim has stepped twice more, i.e. taken it (the frames that arrive meanwhile
      // are queued and answered next)
      if (k == 10 || k == 12 || k == 16 || k == 17 || k == 45) {
        const double wait_end = MonotonicSeconds() + 2.0;
        while (newest < k + 2 && MonotonicSeconds() < wait_end) {
          frames.Wait(0.02);
          take();
          for (const SensorFrame& r : queue) newest = std::max(newest, r.stamp.seq);
        }
      }
    }
  }
  const int code = run.Wait(60.0);
  EXPECT_EQ(code, 1) << run.Output();  // the controller was lost
  const json s = json::parse(ReadText(dir / "out/summary.json"));
  const json& t = s["targets"];
  EXPECT_TRUE(s["controller_lost"].get<bool>()) << s.dump(2);
  EXPECT_EQ(s["exit"], "controller_lost");
  // 14 good targets are sent; a busy machine may let a newer one replace an older one unread
  EXPECT_GE(t["accepted"].get<int>(), 5);
  EXPECT_EQ(t["clamped"]["speed_clamped"], 1);
  EXPECT_EQ(t["rejected"]["out_of_order"], 1);
  EXPECT_EQ(t["rejected"]["unknown_frame"], 1);
  EXPECT_EQ(t["rejected"]["stale"], 1);
  EXPECT_EQ(t["transport_invalid"], 1);  // the NaN target
  EXPECT_GT(t["hold_steps"].get<int>(), 10);
  EXPECT_NE(run.Output().find("inverse_sim left"), std::string::npos) << run.Output();
}

}  // namespace
}  // namespace nsim
