// Bad input to the executables: a clear message naming what was wrong and exit code 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tests/integration/child_process.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;
using testing::ChildProcess;

const std::string kBin = NSIM_BIN_DIR;

struct Case {
  std::vector<std::string> args;
  int code;
  std::string expect;
};

TEST(CliErrors, BadInputExitsWithTwoAndSaysWhy) {
  const fs::path dir = fs::temp_directory_path() / ("nsim_cli_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string bad_csv = (dir / "bad.csv").string();
  std::ofstream(bad_csv) << "t,m0_x,m0_y,m0_z\n0,1,2,3\n0.1,1,oops,3\n";
  const std::string gap_csv = (dir / "gap.csv").string();
  std::ofstream(gap_csv)
      << "t,m0_x,m0_y,m0_z\n0,1,2,3\n0.2,1,2,3\n1000000.2,1,2,3\n1000000.4,1,2,3\n";
  const std::string good_csv = (dir / "good.csv").string();
  std::ofstream(good_csv) << "t,m0_x,m0_y,m0_z\n0,1,2,3\n0.1,1,2,3\n0.2,1,2,3\n";
  const std::string long_partition(65535, 'p');
  const std::vector<Case> cases = {
      {{kBin + "/direct_sim"}, 2, "usage: direct_sim"},
      {{kBin + "/direct_sim", "fly"}, 2, "unknown command 'fly'"},
      {{kBin + "/direct_sim", "replay"}, 2, "missing required option --markers"},
      {{kBin + "/direct_sim", "replay", "--markers", "/nonexistent.csv"},
       2,
       "/nonexistent.csv: cannot open"},
      {{kBin + "/direct_sim", "replay", "--markers", bad_csv},
       2,
       "bad.csv:3:3 (m0_y): expected a number, got 'oops'"},
      {{kBin + "/direct_sim", "replay", "--markers", bad_csv, "--rate-scale", "-1"},
       2,
       "--rate-scale must be > 0"},
      {{kBin + "/direct_sim", "replay", "--markers", bad_csv, "--speed", "2"},
       2,
       "unknown option --speed"},
      {{kBin + "/direct_sim", "replay", "--markers", good_csv, "--ros2-wait", "1"},
       2,
       "--ros2-wait needs --ros2"},
      {{kBin + "/direct_sim", "run", "--config",
        NSIM_SOURCE_DIR "/configs/scenarios/liver_test_coarse.yaml", "--ros2", "--ros2-wait",
        "1001", "--check"},
       2,
       "--ros2-wait: expected an integer in [0, 1000], got 1001"},
      {{kBin + "/inverse_sim", "record"}, 2, "missing required option --out"},
      {{kBin + "/inverse_sim", "record", "--out", "/nonexistent/dir/out.csv"},
       2,
       "cannot open for writing"},
      {{kBin + "/inverse_sim", "record", "--out", (dir / "o.csv").string(), "--domain", "999"},
       2,
       "dds.domain_id must be in 0..232, got 999"},
      {{kBin + "/inverse_sim", "record", "--out", (dir / "o.csv").string(), "--dds-config",
        "/no.xml"},
       2,
       "dds.config_file: no such file '/no.xml'"},
      {{kBin + "/direct_sim", "replay", "--help"}, 0, "--rate-scale X"},
      {{kBin + "/inverse_sim", "--help"}, 0, "record"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "lead0.yaml", "liver_test_coarse.yaml",
                                     {{"search_lead: auto", "search_lead: 0"}})
            .string()},
       2,
       "prediction.search_lead must be >= 1"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "lead_word.yaml", "liver_test_coarse.yaml",
                                     {{"search_lead: auto", "search_lead: soon"}})
            .string()},
       2,
       "prediction.search_lead: expected an integer, got 'soon'"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "interval.yaml", "liver_test_coarse.yaml",
                                     {{"search_interval: 0", "search_interval: -5"}})
            .string()},
       2,
       "prediction.search_interval must be >= 0"},
      // the fuzzing issue: a 65,535-character partition crashed dds_create_writer
      {{kBin + "/direct_sim", "replay", "--markers",
        NSIM_SOURCE_DIR "/configs/markers/breathing_demo.csv", "--partition", long_partition},
       2,
       "--partition must be 1..64 characters of [A-Za-z0-9_-]"},
      {{kBin + "/inverse_sim", "record", "--out", (dir / "o.csv").string(), "--partition",
        long_partition, "--quiet"},
       2,
       "--partition must be 1..64 characters"},
      {{kBin + "/direct_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "partition.yaml", "liver_test_coarse.yaml",
                                     {{"partition: nsim", "partition: " + long_partition}})
            .string(),
        "--check", "--quiet"},
       2,
       "dds.partition must be 1..64 characters"},
      // the loop thread's realtime class: a priority outside SCHED_FIFO's range names the key
      {{kBin + "/direct_sim", "run", "--config",
        NSIM_SOURCE_DIR "/configs/scenarios/liver_test_coarse.yaml", "--rt-priority", "100",
        "--check", "--quiet"},
       2,
       "run.rt_priority must be 0 (the normal class) or a SCHED_FIFO priority in [1, 99], got 100"},
      // a 1e6 s gap in a replayed stream: refused with its line, not slept through
      {{kBin + "/direct_sim", "replay", "--markers", gap_csv, "--wait-readers", "0", "--quiet"},
       2,
       "gap.csv:4:1 (t): a gap of 1e+06 s after t = 0.2 s, more than the 10 s allowed"},
      {{kBin + "/direct_sim", "replay", "--markers", "/dev/zero"},
       2,
       "/dev/zero: expected a regular file as the marker CSV, got a character device"},
      {{kBin + "/direct_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "gravity.yaml", "liver_test_coarse.yaml",
                                     {{"gravity: [0, 0, 0]", "gravity: [0, 0, -1.0e6]"}})
            .string(),
        "--no-controller", "--quiet"},
       2,
       "patient.gravity must be finite with a norm of at most 100 (m/s^2)"},
      {{kBin + "/direct_sim", "run", "--config",
        testing::WriteEditedScenario(
            dir, "tip_compliance.yaml", "liver_test_coarse.yaml",
            {{"liver: {puncture_force: 0.3, friction_coefficient: 0.1, point_spacing: 0.013}",
              "liver: {puncture_force: 0.3, friction_coefficient: 0.1, point_spacing: 0.013, "
              "tip_compliance: -0.001}"}})
            .string(),
        "--check"},
       2,
       "needle.liver.tip_compliance must be >= 0 (m/N)"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(
            dir, "lateral_compliance.yaml", "liver_test_coarse.yaml",
            {{"  point_spacing: 0.013\n", "  point_spacing: 0.013\n  lateral_compliance: 5.0\n"}})
            .string(),
        "--check", "--quiet"},
       2,
       "inverse.lateral_compliance must be <= 1 (m/N), got 5"},
      // an emulated network delay is a realtime run's; lockstep has its latency in steps
      {{kBin + "/inverse_sim", "run", "--config",
        NSIM_SOURCE_DIR "/configs/scenarios/liver_test_coarse.yaml", "--mode", "lockstep",
        "--link-delay", "0.04", "--check"},
       2,
       "--link-delay is for realtime runs over DDS"},
      {{kBin + "/inverse_sim", "run", "--config",
        NSIM_SOURCE_DIR "/configs/scenarios/liver_test_coarse.yaml", "--mode", "realtime",
        "--link-delay", "-1", "--check"},
       2,
       "--link-delay must be in [0, 10] (s), got -1"},
      {{kBin + "/direct_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "dup.yaml", "liver_test_coarse.yaml",
                                     {{"duration: 8.0", "duration: 8.0\n  duration: 9.0"}})
            .string(),
        "--check"},
       2,
       "duplicate key run.duration"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(dir, "dup_inverse.yaml", "liver_test_coarse.yaml",
                                     {{"order: 2", "order: 2\n  order: 1"}})
            .string(),
        "--check", "--quiet"},
       2,
       "duplicate key prediction.order"},
      {{kBin + "/inverse_sim", "run", "--config",
        testing::WriteEditedScenario(
            dir, "mesh_dev.yaml", "liver_test_coarse.yaml",
            {{NSIM_SOURCE_DIR "/configs/meshes/liver_700.msh  # coarser", "/dev/zero  # coarser"}})
            .string(),
        "--check"},
       2,
       "/dev/zero: expected a regular file as the mesh file"},
      {{kBin + "/inverse_sim", "predict-eval", "--markers", gap_csv, "--out",
        (dir / "pe").string()},
       2,
       "gap.csv:4:1 (t): a gap of 1e+06 s after t = 0.2 s, more than 10 times the median"},
  };
  int i = 0;
  for (const Case& c : cases) {
    ChildProcess p(c.args, (dir / ("case" + std::to_string(i++) + ".log")).string());
    EXPECT_EQ(p.Wait(20), c.code) << p.Output();
    EXPECT_NE(p.Output().find(c.expect), std::string::npos)
        << "args[1..]: " << (c.args.size() > 1 ? c.args[1] : "") << "\noutput: " << p.Output();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace nsim
