// direct_sim replay -> DDS (loopback) -> inverse_sim record, as two processes.
#include <gtest/gtest.h>

#include <fstream>

#include <csignal>

#include <thread>

#include <chrono>
#include <filesystem>
#include <random>

#include "common/markers/marker_csv.h"
#include "tests/integration/child_process.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;
using testing::Cat;
using testing::ChildProcess;
using testing::ReadText;
using testing::TempDir;

const std::string kBin = NSIM_BIN_DIR;

MarkerStream BreathingLikeStream(int markers, int frames, double rate_hz, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, 1e-4);
  MarkerStream s;
  s.num_markers = markers;
  for (int k = 0; k < frames; ++k) {
    MarkerFrame f;
    f.stamp.seq = k;
    f.stamp.sim_time = k / rate_hz;
    const double c = std::cos(M_PI * f.stamp.sim_time / 4.0);
    for (int m = 0; m < markers; ++m)
      f.p_WM.emplace_back(0.02 * m + noise(rng), 0.003 * c * c + noise(rng),
                          0.012 * c * c * c * c + noise(rng));
    s.frames.push_back(f);
  }
  return s;
}

TEST(ReplayRecord, RecordingEqualsTheStreamValueForValueAndInOrder) {
  const fs::path dir = TempDir("roundtrip");
  const MarkerStream stream = BreathingLikeStream(5, 300, 100.0, 3);
  WriteMarkerCsv((dir / "in.csv").string(), stream);
  const std::string partition = "roundtrip_" + std::to_string(getpid());

  ChildProcess record(Cat({kBin + "/inverse_sim", "record", "--out", (dir / "out.csv").string(),
                           "--summary", (dir / "summary.json").string(), "--timeout", "60"},
                          testing::DdsArgs(31, partition)),
                      (dir / "record.log").string());
  ChildProcess replay(Cat({kBin + "/direct_sim", "replay", "--markers", (dir / "in.csv").string(),
                           "--rate-scale", "3", "--wait-timeout", "30"},
                          testing::DdsArgs(31, partition)),
                      (dir / "replay.log").string());
  const int replay_code = replay.Wait(60);
  const int record_code = record.Wait(60);
  ASSERT_EQ(replay_code, 0) << replay.Output();
  ASSERT_EQ(record_code, 0) << record.Output();
  EXPECT_NE(record.Output().find("received=300 written=300 missing=0 out_of_order=0 invalid=0"),
            std::string::npos)
      << record.Output();

  const MarkerStream got = ReadMarkerCsv((dir / "out.csv").string());
  ASSERT_EQ(got.num_markers, stream.num_markers);
  ASSERT_EQ(got.frames.size(), stream.frames.size());
  for (size_t k = 0; k < got.frames.size(); ++k) {
    ASSERT_EQ(got.frames[k].stamp.sim_time, stream.frames[k].stamp.sim_time) << "frame " << k;
    for (int m = 0; m < stream.num_markers; ++m)
      ASSERT_EQ(got.frames[k].p_WM[m], stream.frames[k].p_WM[m])
          << "frame " << k << " marker " << m;
  }
  fs::remove_all(dir);
}

TEST(ReplayRecord, KilledPublisherIsReportedWithinTheLivelinessLease) {
  const fs::path dir = TempDir("liveliness");
  WriteMarkerCsv((dir / "in.csv").string(), BreathingLikeStream(3, 1800, 30.0, 4));  // 60 s
  const std::string partition = "liveliness_" + std::to_string(getpid());
  const double lease_s = 0.3;
  // detection bound: the lease plus the reader's polling period and process scheduling
  const double allowed_s = lease_s + 0.7;

  ChildProcess record(
      Cat({kBin + "/inverse_sim", "record", "--out", (dir / "out.csv").string(), "--timeout", "60"},
          testing::DdsArgs(32, partition)),
      (dir / "record.log").string());
  ChildProcess replay(Cat({kBin + "/direct_sim", "replay", "--markers", (dir / "in.csv").string(),
                           "--lease", std::to_string(lease_s)},
                          testing::DdsArgs(32, partition)),
                      (dir / "replay.log").string());
  // wait until frames flow
  const auto start = std::chrono::steady_clock::now();
  while (record.Output().find("record: ") == std::string::npos &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_NE(record.Output().find("record: "), std::string::npos)
      << "no frames: " << replay.Output();

  replay.Kill(SIGKILL);
  const auto killed_at = std::chrono::steady_clock::now();
  const int code = record.Wait(30);
  const double detect_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - killed_at).count();
  EXPECT_EQ(code, 1) << record.Output();
  EXPECT_NE(record.Output().find("publisher_lost"), std::string::npos) << record.Output();
  EXPECT_LT(detect_s, allowed_s) << "lease " << lease_s << " s";
  std::printf("publisher death noticed %.3f s after the kill (lease %.3f s)\n", detect_s, lease_s);
  // what was recorded before the death is a valid marker CSV
  EXPECT_GT(ReadMarkerCsv((dir / "out.csv").string()).frames.size(), 0u);
  fs::remove_all(dir);
}

// A replay waiting through a long (legal) pause in its stream stops within 0.5 s of SIGTERM
// and of SIGINT: it sleeps in slices of 0.1 s checking for the signal.
TEST(ReplayRecord, ReplayHonoursSigtermAndSigintDuringALongPause) {
  const fs::path dir = TempDir("interrupt");
  // 0.1 s frames, then a 9 s pause (90 intervals, under the 100 allowed), then two more
  std::ofstream(dir / "pause.csv") << "t,m0_x,m0_y,m0_z\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n"
                                      "0.3,0,0,0\n9.3,0,0,0\n9.4,0,0,0\n";
  for (const int sig : {SIGTERM, SIGINT}) {
    const std::string partition = "interrupt_" + std::to_string(getpid()) + "_" +
                                  std::to_string(sig);
    ChildProcess replay(Cat({kBin + "/direct_sim", "replay", "--markers",
                             (dir / "pause.csv").string(), "--wait-readers", "0"},
                            testing::DdsArgs(33, partition)),
                        (dir / ("replay" + std::to_string(sig) + ".log")).string());
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // in the pause by now
    const auto sent = std::chrono::steady_clock::now();
    replay.Kill(sig);
    const int code = replay.Wait(5);
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
    EXPECT_EQ(code, 1) << replay.Output();
    EXPECT_LT(took, 0.5) << "signal " << sig << ": stopped after " << took << " s";
    EXPECT_NE(replay.Output().find("interrupted"), std::string::npos) << replay.Output();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace nsim
