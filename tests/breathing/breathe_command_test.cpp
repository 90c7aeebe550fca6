#include "direct_sim/breathe_command.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "common/core/error.h"
#include "common/markers/marker_csv.h"
#include "tests/integration/test_util.h"

namespace nsim {
namespace {

// argv from strings; argv[0] is the subcommand
int RunCommand(std::vector<std::string> args) {
  args.insert(args.begin(), "breathe");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return RunBreathe(static_cast<int>(argv.size()), argv.data());
}

using testing::ReadText;

// a file in the running test's own temporary folder (removed when the test passes)
std::string TempPath(const std::string& name) { return (testing::TestTempDir() / name).string(); }

TEST(BreatheCommand, WritesAReadableStreamReproducibly) {
  const std::string a = TempPath("a.csv"), b = TempPath("b.csv"), c = TempPath("c.csv");
  EXPECT_EQ(
      RunCommand({"--out", a, "--duration", "10", "--rate", "20", "--markers", "3", "--seed", "4"}),
      0);
  EXPECT_EQ(
      RunCommand({"--out", b, "--duration", "10", "--rate", "20", "--markers", "3", "--seed", "4"}),
      0);
  EXPECT_EQ(
      RunCommand({"--out", c, "--duration", "10", "--rate", "20", "--markers", "3", "--seed", "5"}),
      0);
  const MarkerStream stream = ReadMarkerCsv(a);
  EXPECT_EQ(stream.num_markers, 3);
  ASSERT_EQ(stream.frames.size(), 201u);
  EXPECT_DOUBLE_EQ(stream.frames.back().stamp.sim_time, 10.0);
  EXPECT_EQ(ReadText(a), ReadText(b));
  EXPECT_NE(ReadText(a), ReadText(c));
  // the motion is SI dominant: z range larger than x range for every marker
  for (int m = 0; m < 3; ++m) {
    double z_lo = 1, z_hi = -1, x_lo = 1, x_hi = -1;
    for (const auto& f : stream.frames) {
      z_lo = std::min(z_lo, f.p_WM[m].z());
      z_hi = std::max(z_hi, f.p_WM[m].z());
      x_lo = std::min(x_lo, f.p_WM[m].x());
      x_hi = std::max(x_hi, f.p_WM[m].x());
    }
    EXPECT_GT(z_hi - z_lo, 2 * (x_hi - x_lo));
  }
}

TEST(BreatheCommand, HelpReturnsZero) { EXPECT_EQ(RunCommand({"--help"}), 0); }

TEST(BreatheCommand, BadValuesThrowInputErrorNamingTheProblem) {
  auto message = [](std::vector<std::string> args) -> std::string {
    try {
      RunCommand(std::move(args));
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const std::string out = TempPath("bad.csv");
  EXPECT_EQ(message({"--out", out, "--period", "-1"}), "breathing.period must be > 0 (s), got -1");
  EXPECT_EQ(message({"--out", out, "--rate", "abc"}),
            "--rate: expected a finite number, got 'abc'");
  EXPECT_EQ(message({"--out", out, "--markers", "0"}), "--markers must be in [1, 100], got 0");
  EXPECT_EQ(message({"--out", out, "--drift", "1,2"}),
            "--drift: expected three comma-separated numbers x,y,z, got '1,2'");
  EXPECT_EQ(message({"--duration", "5"}), "missing required option --out FILE");
}

}  // namespace
}  // namespace nsim
