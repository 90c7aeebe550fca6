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
