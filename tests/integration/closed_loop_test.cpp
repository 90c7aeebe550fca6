// The closed loop as two processes over DDS (configs/dds/local.xml), lockstep, on the coarse
// scenario configs/scenarios/liver_test_coarse.yaml (liver_700 on both sides): the needle
// reaches the target and the run is reproducible; a controller killed with SIGKILL mid-insertion
// makes direct_sim hold the robot and report it (a process that never says "running" cannot
// take it over); a prediction-on run scores every marker's prediction better than not
// predicting (nRMS < 100 %). Every process is bounded in time and killed by PID.
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/core/clock.h"
#include "messages/transport.h"
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
using testing::kDdsConfig;
using testing::ReadText;
using testing::TempDir;
constexpr int kDomain = 44;

using testing::Loop;
using testing::ReadRows;
using testing::WriteScenario;

// Tolerance: the steady-state error of this scenario is 0.40 mm, its amplitude 0.44 mm
// (measured, 11 s: the tip reaches the target after about 8 s with the scenario's gain 0.1);
// 2 mm is the tolerance the test states (the tip starts 65 mm from the target).
constexpr double kReachToleranceMm = 2.0;

// The same insertion over DDS (two processes, lockstep) and in one process (both loops,
// lockstep, no network): the same timeseries.csv byte for byte (17 significant digits) and the
// same final error, so the in-process batches stand for the two-process runs.
TEST(ClosedLoop, LockstepInsertionReachesTheTargetAndEqualsTheInProcessRun) {
  const fs::path dir = TempDir("closed_loop_reach");
  const fs::path scenario = WriteScenario(dir, {});
  const std::vector<std::string> direct = {"--duration", "11"};
  const std::vector<std::string> inverse = {"--prediction", "off"};
  Loop a(dir, "a", scenario, direct, inverse);
  const fs::path in_process = dir / "in_process";
  ChildProcess one(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                        (in_process / "direct").string(), "--in-process", "--duration", "11",
                        "--prediction", "off", "--no-video", "--quiet"},
                       {}),
                   (dir / "in_process.log").string());
  ASSERT_EQ(a.direct->Wait(85.0), 0) << a.direct->Output() << a.inverse->Output();
  EXPECT_EQ(a.inverse->Wait(10.0), 0) << a.inverse->Output();
  ASSERT_EQ(one.Wait(85.0), 0) << one.Output();

  const json d = a.DirectSummary(), i = a.InverseSummary();
  EXPECT_EQ(d["exit"], "completed");
  EXPECT_EQ(d["steps"], 550);
  EXPECT_TRUE(d["punctured"]["skin"]["punctured"].get<bool>());
  EXPECT_TRUE(d["punctured"]["liver"]["punctured"].get<bool>());
  EXPECT_LT(d["final_error_mm"].get<double>(), kReachToleranceMm);
  EXPECT_LT(d["final_error_amplitude_mm"].get<double>(), kReachToleranceMm);
  EXPECT_EQ(d["targets"]["rejected_total"], 0);
  EXPECT_EQ(d["targets"]["lockstep_timeouts"], 0);
  EXPECT_EQ(d["targets"]["accepted"], 549);  // frames 0..548 answer steps 1..549
  EXPECT_GE(d["loop_latency_ms"]["count"].get<int>(), 549);
  EXPECT_GT(d["loop_latency_ms"]["mean"].get<double>(), 0.0);
  EXPECT_EQ(i["ending"], "direct_finished");
  // every frame answered, the final state (frame 550) too, even when direct_sim's finished
  // status arrives before the last frames' samples
  EXPECT_EQ(i["targets_sent"], 551);
  EXPECT_EQ(i["frames_skipped"], 0);
  EXPECT_EQ(i["rejected_frames"], 0);
  EXPECT_GT(i["inverse_rate_hz"].get<double>(), 0.0);

  const json d1 = json::parse(ReadText(in_process / "direct/summary.json"));
  const json i1 = json::parse(ReadText(in_process / "inverse/summary.json"));
  EXPECT_EQ(d1["transport"], "in_process");
  EXPECT_EQ(d1["exit"], "completed");
  EXPECT_EQ(d1["final_error_mm"].get<double>(), d["final_error_mm"].get<double>());
  EXPECT_EQ(d1["final_error_amplitude_mm"].get<double>(),
            d["final_error_amplitude_mm"].get<double>());
  EXPECT_EQ(d1["targets"]["accepted"], d["targets"]["accepted"]);
  EXPECT_EQ(i1["targets_sent"], i["targets_sent"]);
  const std::string dds_series = a.Timeseries();
  EXPECT_GT(std::count(dds_series.begin(), dds_series.end(), '\n'), 551);
  EXPECT_TRUE(dds_series == ReadText(in_process / "direct/timeseries.csv"))
      << "timeseries.csv differs between the DDS and the in-process run";
}

// both processes must run the same shared part of a scenario: a controller planning another
// target is refused at the start handshake, by both sides, with a message that says so
TEST(ClosedLoop, AControllerWithAnotherScenarioIsRefused) {
  const fs::path dir = TempDir("closed_loop_mismatch");
  const fs::path scenario = WriteScenario(dir, {});
  const fs::path other = testing::WriteEditedScenario(
      dir, "other.yaml", "liver_test_coarse.yaml",
      {{"target: [0.03, 0.015, -0.01]", "target: [0.03, 0.015, -0.012]"}});
  Loop loop(dir, "mismatch", scenario, {"--duration", "2"}, {"--prediction", "off"}, other);
  EXPECT_EQ(loop.direct->Wait(60.0), 2) << loop.direct->Output();
  EXPECT_EQ(loop.inverse->Wait(30.0), 2) << loop.inverse->Output();
  EXPECT_NE(loop.direct->Output().find("runs another scenario"), std::string::npos)
      << loop.direct->Output();
  EXPECT_NE(loop.inverse->Output().find("another scenario"), std::string::npos)
      << loop.inverse->Output();
  EXPECT_EQ(loop.DirectSummary()["exit"], "scenario_mismatch");
  EXPECT_EQ(loop.DirectSummary()["steps"], 0);
}

// One owner of the robot: a second process on the domain answering every frame with a target
// 45 mm off is detected and rejected, and moves the robot 0 mm: the run equals, byte for byte,
// the same run without it (in-process, no DDS at all).
TEST(ClosedLoop, AnInjectorOfTargetsMovesTheRobotZeroMillimetres) {
  const fs::path dir = TempDir("closed_loop_inject");
  const fs::path scenario = WriteScenario(dir, {});
  const std::string partition = "inject_" + std::to_string(getpid());
  transport::TransportConfig tc;
  tc.domain_id = kDomain;
  tc.partition = partition;
  tc.config_file = kDdsConfig;
  transport::Participant injector(tc);
  transport::Reader<SensorFrame> frames(injector, transport::Qos::kLossless);
  transport::Writer<RobotTarget> targets(injector, transport::Qos::kLossless);
  Loop loop(dir, "inject", scenario, {"--duration", "4"}, {"--prediction", "off"});
  ChildProcess alone(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                          (dir / "alone/direct").string(), "--in-process", "--duration", "4",
                          "--prediction", "off", "--no-video", "--quiet"},
                         {}),
                     (dir / "alone.log").string());
  std::vector<SensorFrame> got;
  uint64_t injected = 0;
  const double end = MonotonicSeconds() + 80.0;
  while (!loop.direct->Exited() && MonotonicSeconds() < end) {
    frames.Wait(0.05);
    got.clear();
    frames.Take(got);
    for (const SensorFrame& f : got) {
      RobotTarget t;
      t.stamp.seq = injected++;
      t.answers_seq = f.stamp.seq;
      t.X_WE = f.X_WE;
      t.X_WE.translation() += Eigen::Vector3d(0.045, 0.0, 0.0);
      targets.Write(t);
    }
  }
  ASSERT_EQ(loop.direct->Wait(30.0), 0) << loop.direct->Output();
  EXPECT_EQ(loop.inverse->Wait(10.0), 0) << loop.inverse->Output();
  ASSERT_EQ(alone.Wait(60.0), 0) << alone.Output();
  ASSERT_GT(injected, 100u);
  const json d = loop.DirectSummary();
  EXPECT_EQ(d["exit"], "completed");
  EXPECT_GT(d["targets"]["foreign"].get<uint64_t>(), 100u) << d["targets"].dump();
  EXPECT_EQ(d["targets"]["foreign_by_writer"].size(), 1u);
  EXPECT_EQ(d["targets"]["rejected_total"], 0);  // the gate never saw them
  EXPECT_NE(loop.direct->Output().find("does not own the robot"), std::string::npos);
  EXPECT_TRUE(loop.Timeseries() == ReadText(dir / "alone/direct/timeseries.csv"))
      << "the injector changed the run";
}

// A controller stopped (SIGSTOP) for 3 s mid-insertion, longer than its 1 s liveliness lease:
// direct_sim notices the loss, holds the robot and waits; the controller resumes (SIGCONT),
// owns the robot again and catches up; in lockstep the run ends exactly as an undisturbed one
// (the same timeseries.csv as the in-process run, byte for byte).
TEST(ClosedLoop, AStalledControllerTakesOverAgainAndTheRunIsUnchanged) {
  const fs::path dir = TempDir("closed_loop_stall");
  const fs::path scenario = WriteScenario(dir, {});
  Loop loop(dir, "stall", scenario, {"--duration", "5"}, {"--prediction", "off", "--lease", "1"});
  ChildProcess alone(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                          (dir / "alone/direct").string(), "--in-process", "--duration", "5",
                          "--prediction", "off", "--no-video", "--quiet"},
                         {}),
                     (dir / "alone.log").string());
  // stop the controller once the insertion is under way (frames of 1 s simulated written)
  const fs::path csv = loop.out / "direct/timeseries.csv";
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < end) {
    const std::string text = ReadText(csv);
    if (std::count(text.begin(), text.end(), '\n') > 50) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  loop.inverse->Kill(SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  loop.inverse->Kill(SIGCONT);
  ASSERT_EQ(loop.direct->Wait(80.0), 0) << loop.direct->Output();
  EXPECT_EQ(loop.inverse->Wait(20.0), 0) << loop.inverse->Output();
  ASSERT_EQ(alone.Wait(60.0), 0) << alone.Output();
  const json d = loop.DirectSummary();
  EXPECT_EQ(d["exit"], "completed");
  EXPECT_GE(d["controller_losses"].get<int>(), 1) << loop.direct->Output();
  EXPECT_EQ(d["controller_returns"], d["controller_losses"]);
  EXPECT_NE(loop.direct->Output().find("inverse_sim back"), std::string::npos);
  EXPECT_TRUE(loop.Timeseries() == ReadText(dir / "alone/direct/timeseries.csv"))
      << "the stall changed the run";
}

// The patient stalled: direct_sim stopped (SIGSTOP) for 4 s, longer than its 3 s lease. The
// controller sees it not alive and waits (--direct-timeout, 30 s); direct_sim resumes, each
// side sees the other back, and in lockstep the run ends exactly as the in-process run.
TEST(ClosedLoop, AStalledPatientIsWaitedForAndTheRunIsUnchanged) {
  const fs::path dir = TempDir("closed_loop_patient_stall");
  const fs::path scenario = WriteScenario(dir, {});
  Loop loop(dir, "pstall", scenario, {"--duration", "4"}, {"--prediction", "off"});
  ChildProcess alone(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                          (dir / "alone/direct").string(), "--in-process", "--duration", "4",
                          "--prediction", "off", "--no-video", "--quiet"},
                         {}),
                     (dir / "alone.log").string());
  const fs::path csv = loop.out / "direct/timeseries.csv";
  ASSERT_TRUE(testing::WaitForRow(csv, [](const std::vector<double>& row) {
    return !row.empty() && row[0] >= 1.0;
  })) << loop.direct->Output();
  loop.direct->Kill(SIGSTOP);
  std::this_thread::sleep_for(std::chrono::seconds(4));
  loop.direct->Kill(SIGCONT);
  ASSERT_EQ(loop.direct->Wait(80.0), 0) << loop.direct->Output() << loop.inverse->Output();
  EXPECT_EQ(loop.inverse->Wait(20.0), 0) << loop.inverse->Output();
  ASSERT_EQ(alone.Wait(60.0), 0) << alone.Output();
  const json i = loop.InverseSummary();
  EXPECT_EQ(i["ending"], "direct_finished");
  EXPECT_GE(i["direct_losses"].get<int>(), 1) << loop.inverse->Output();
  EXPECT_NE(loop.inverse->Output().find("direct_sim back after"), std::string::npos)
      << loop.inverse->Output();
  EXPECT_EQ(loop.DirectSummary()["exit"], "completed");
  EXPECT_TRUE(loop.Timeseries() == ReadText(dir / "alone/direct/timeseries.csv"))
      << "the stall changed the run";
}

// A patient that dies: the controller gives up after --direct-timeout and says so.
TEST(ClosedLoop, AControllerGivesUpOnAKilledPatient) {
  const fs::path dir = TempDir("closed_loop_patient_kill");
  const fs::path scenario = WriteScenario(dir, {});
  Loop loop(dir, "pkill", scenario, {"--duration", "5"},
            {"--prediction", "off", "--direct-timeout", "2"});
  const fs::path csv = loop.out / "direct/timeseries.csv";
  ASSERT_TRUE(testing::WaitForRow(csv, [](const std::vector<double>& row) {
    return !row.empty() && row[0] >= 0.5;
  })) << loop.direct->Output();
  loop.direct->Kill(SIGKILL);
  const double killed = MonotonicSeconds();
  EXPECT_EQ(loop.inverse->Wait(30.0), 1) << loop.inverse->Output();
  // the 3 s lease, then the 2 s of --direct-timeout
  EXPECT_GT(MonotonicSeconds() - killed, 2.0);
  const json i = loop.InverseSummary();
  EXPECT_EQ(i["ending"], "direct_lost");
  EXPECT_EQ(i["direct_losses"], 1);
  EXPECT_NE(loop.inverse->Output().find("direct_sim lost (not alive for"), std::string::npos)
      << loop.inverse->Output();
}

// A killed controller that no new one replaces: the robot holds to the end. A process that
// answers every frame but never says "running" (an injector, 45 mm off) cannot take it over.
TEST(ClosedLoop, KilledControllerMakesTheRobotHold) {
  const fs::path dir = TempDir("closed_loop_kill");
  // a killed controller does not come back: the loss is final after 2 s
  const fs::path scenario =
      WriteScenario(dir, {{"takeover_timeout: 30.0", "takeover_timeout: 2.0"}});
  transport::TransportConfig tc;
  tc.domain_id = kDomain;
  tc.partition = "kill_" + std::to_string(getpid());  // the loop's partition
  tc.config_file = kDdsConfig;
  transport::Participant injector(tc);
  transport::Reader<SensorFrame> frames(injector, transport::Qos::kLossless);
  transport::Writer<RobotTarget> targets(injector, transport::Qos::kLossless);
  Loop loop(dir, "kill", scenario, {"--duration", "5"}, {"--prediction", "off", "--lease", "0.5"});
  // kill the controller once the needle is in the skin (phase >= 1) and moving
  const fs::path csv = loop.out / "direct/timeseries.csv";
  const bool in_skin = testing::WaitForRow(csv, [](const std::vector<double>& row) {
    return row.size() > 5 && row[5] >= 1;
  });
  ASSERT_TRUE(in_skin) << loop.direct->Output();
  loop.inverse->Kill(SIGKILL);
  std::vector<SensorFrame> got;
  uint64_t injected = 0;
  const double until = MonotonicSeconds() + 60.0;
  while (!loop.direct->Exited() && MonotonicSeconds() < until) {
    frames.Wait(0.05);
    got.clear();
    frames.Take(got);
    for (const SensorFrame& f : got) {
      RobotTarget t;
      t.stamp.seq = injected++;
      t.answers_seq = f.stamp.seq;
      t.X_WE = f.X_WE;
      t.X_WE.translation() += Eigen::Vector3d(0.045, 0.0, 0.0);
      targets.Write(t);
    }
  }
  const int code = loop.direct->Wait(60.0);
  const std::string output = loop.direct->Output();
  EXPECT_EQ(code, 1) << output;
  EXPECT_NE(output.find("inverse_sim lost"), std::string::npos) << output;
  EXPECT_NE(output.find("robot holds"), std::string::npos) << output;

  const json d = loop.DirectSummary();
  EXPECT_EQ(d["exit"], "controller_lost");
  EXPECT_TRUE(d["controller_lost"].get<bool>());
  const double lost_at = d["controller_lost_time_s"].get<double>();
  EXPECT_GT(lost_at, 0.0);
  EXPECT_LT(lost_at, 4.5);
  EXPECT_EQ(d["steps"], 250);  // it keeps simulating the patient to the end
  EXPECT_EQ(d["controller_takeovers"], 0);
  EXPECT_GT(d["targets"]["foreign"].get<uint64_t>(), 50u) << d["targets"].dump();
  // the robot holds: after braking (<= 0.1 s at the robot's acceleration limit) it stays put
  const std::vector<std::vector<double>> rows = ReadRows(csv);
  ASSERT_FALSE(rows.empty());
  const std::vector<double>& final_row = rows.back();
  int held_rows = 0;
  for (const auto& r : rows) {
    if (r[0] < lost_at + 0.2) continue;
    ++held_rows;
    for (int c = 15; c <= 21; ++c) EXPECT_NEAR(r[c], final_row[c], 1e-12) << "t = " << r[0];
    EXPECT_EQ(r[22], 1.0) << "holding at t = " << r[0];
  }
  EXPECT_GT(held_rows, 10);
}

// Realtime with a slower network emulated in the controller (--link-delay 0.04: each frame taken
// up and each target written 40 ms late): the controller measures the longer delay from the
// frames that report which target the robot applied, and predicts over it; nothing is
// configured besides the delay itself.
TEST(ClosedLoop, InRealtimeALinkDelayIsMeasuredAndPredictedOver) {
  const fs::path dir = TempDir("closed_loop_link_delay");
  const fs::path scenario = WriteScenario(dir, {{"mode: lockstep ", "mode: realtime "},
                                                {"pca_window: 300", "pca_window: 100"}});
  Loop loop(dir, "delay", scenario, {"--duration", "10"},
            {"--prediction", "on", "--link-delay", "0.04"});
  ASSERT_EQ(loop.direct->Wait(85.0), 0) << loop.direct->Output() << loop.inverse->Output();
  EXPECT_EQ(loop.inverse->Wait(10.0), 0) << loop.inverse->Output();
  const json d = loop.DirectSummary(), i = loop.InverseSummary();
  EXPECT_EQ(d["exit"], "completed");
  EXPECT_EQ(i["link_delay_ms"].get<double>(), 40.0);
  // without the delay this machine measures 40 ms (the frame period and one of latency); the
  // delay adds 80 ms (40 each way). A frame published at t is answered at t + 40 ms at the
  // earliest and the target reaches direct_sim 40 ms later: its mean is over 80 ms
  const double measured = i["measured_loop_delay_ms"]["median"].get<double>();
  EXPECT_GE(measured, 100.0);
  EXPECT_LE(measured, 200.0);
  EXPECT_GT(d["loop_latency_ms"]["mean"].get<double>(), 80.0);
  // the window search scores the measured horizon in frames (search_lead auto), 5 or more
  EXPECT_GE(i["settings"]["search_lead"].get<int>(), 5);
  EXPECT_GT(i["predictions_scored"].get<int>(), 200);
  EXPECT_LT(d["final_error_mm"].get<double>(), kReachToleranceMm);
}

TEST(ClosedLoop, PredictionBeatsNoPredictionForEveryMarker) {
  const fs::path dir = TempDir("closed_loop_nrms");
  // a shorter PCA buffer (2 s instead of 6 s) so the predictor is ready early in a short run
  const fs::path scenario = WriteScenario(dir, {{"pca_window: 300", "pca_window: 100"}});
  Loop loop(dir, "nrms", scenario, {"--duration", "11", "--latency-steps", "2"},
            {"--prediction", "on"});
  ASSERT_EQ(loop.direct->Wait(85.0), 0) << loop.direct->Output() << loop.inverse->Output();
  EXPECT_EQ(loop.inverse->Wait(10.0), 0) << loop.inverse->Output();
  const json d = loop.DirectSummary(), i = loop.InverseSummary();
  // two steps of latency: the steady error is larger (1.14 mm measured) than with one (0.40 mm)
  EXPECT_LT(d["final_error_mm"].get<double>(), 3.0);
  EXPECT_TRUE(i["settings"]["prediction"].get<bool>());
  // the controller measured its loop delay: (2 + 1) steps of 0.02 s, and the window search
  // scores that horizon in frames (search_lead auto)
  EXPECT_NEAR(i["measured_loop_delay_ms"]["median"].get<double>(), 60.0, 1e-6);
  EXPECT_EQ(i["settings"]["search_lead"].get<int>(), 3);
  EXPECT_GT(i["predictions_scored"].get<int>(), 400);  // 450 from t = 2 s to 11 s
  ASSERT_EQ(i["nrms_percent"].size(), 5u);
  for (size_t m = 0; m < 5; ++m) {
    ASSERT_TRUE(i["nrms_percent"][m].is_number()) << "marker " << m;
    EXPECT_GT(i["nrms_percent"][m].get<double>(), 0.0) << "marker " << m;
    EXPECT_LT(i["nrms_percent"][m].get<double>(), 100.0) << "marker " << m;
    // the mean prediction error (bias) is a small part of its RMS (0.02 of 0.1-0.4 mm measured)
    ASSERT_EQ(i["prediction_bias_mm"][m].size(), 3u) << "marker " << m;
    Eigen::Vector3d bias;
    for (int a = 0; a < 3; ++a) bias[a] = i["prediction_bias_mm"][m][a].get<double>();
    EXPECT_LT(bias.norm(), 0.5 * i["prediction_rms_mm"][m].get<double>()) << "marker " << m;
    // the regression window the search chose, within its range [order + 1, window_max - 1]
    ASSERT_EQ(i["prediction_windows"].size(), 5u);
    EXPECT_GE(i["prediction_windows"][m].get<int>(), 3) << "marker " << m;
    EXPECT_LE(i["prediction_windows"][m].get<int>(), 59) << "marker " << m;
    // without prediction.shrink the model registers to the predictor's own predictions: the
    // two scores are of the same predictions; the shrinkage factor is still measured
    EXPECT_FALSE(i["settings"]["prediction_shrink"].get<bool>());
    EXPECT_EQ(i["settings"]["model_pose"].get<std::string>(), "measured");
    EXPECT_EQ(i["predictor_nrms_percent"][m].get<double>(), i["nrms_percent"][m].get<double>());
    EXPECT_GE(i["prediction_shrinkage"][m].get<double>(), 0.0) << "marker " << m;
    EXPECT_LE(i["prediction_shrinkage"][m].get<double>(), 1.0) << "marker " << m;
  }
}

}  // namespace
}  // namespace nsim
