#include "common/core/cli.h"

#include <gtest/gtest.h>

#include <vector>

#include "common/core/error.h"

namespace nsim {
namespace {

struct Argv {
  explicit Argv(std::vector<std::string> a) : args(std::move(a)) {
    for (auto& s : args) ptrs.push_back(s.data());
  }
  int argc() { return static_cast<int>(ptrs.size()); }
  char** argv() { return ptrs.data(); }
  std::vector<std::string> args;
  std::vector<char*> ptrs;
};

CommandLine MakeCli() {
  CommandLine cli("prog cmd", "test");
  cli.Option("markers", "FILE", "input", "", true)
      .Option("rate", "X", "rate", "1.5")
      .Flag("quiet", "q");
  return cli;
}

TEST(CommandLine, ParsesOptionsFlagsAndDefaults) {
  Argv a({"cmd", "--markers", "in.csv", "--quiet"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_EQ(cli.GetString("markers"), "in.csv");
  EXPECT_DOUBLE_EQ(cli.GetDouble("rate"), 1.5);
  EXPECT_TRUE(cli.GetFlag("quiet"));
}

TEST(CommandLine, AcceptsEqualsSyntax) {
  Argv a({"cmd", "--markers=x.csv", "--rate=3"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_EQ(cli.GetString("markers"), "x.csv");
  EXPECT_DOUBLE_EQ(cli.GetDouble("rate"), 3.0);
  EXPECT_FALSE(cli.GetFlag("quiet"));
}

void ExpectInputError(std::vector<std::string> args, const std::string& fragment) {
  Argv a(std::move(args));
  CommandLine cli = MakeCli();
  try {
    cli.Parse(a.argc(), a.argv(), 1);
    cli.GetDouble("rate");
    FAIL() << "expected InputError containing '" << fragment << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(CommandLine, BadInputNamesTheProblem) {
  ExpectInputError({"cmd", "--markers", "a", "--bogus", "1"}, "unknown option --bogus");
  ExpectInputError({"cmd"}, "missing required option --markers");
  ExpectInputError({"cmd", "--markers"}, "--markers expects a value");
  ExpectInputError({"cmd", "--markers", "a", "--rate", "fast"},
                   "--rate: expected a finite number, got 'fast'");
  ExpectInputError({"cmd", "--markers", "a", "--rate", "nan"}, "--rate: expected a finite number");
  ExpectInputError({"cmd", "--markers", "a", "stray"}, "unexpected argument 'stray'");
  ExpectInputError({"cmd", "--markers", "a", "--", "stray"}, "unexpected argument '--'");
  ExpectInputError({"cmd", "--markers", "a", "-7"}, "unexpected argument '-7'");
  ExpectInputError({"cmd", "--markers", "a", "--quiet=1"}, "--quiet takes no value");
}

TEST(CommandLine, HelpSkipsRequiredChecksAndListsOptions) {
  Argv a({"cmd", "--help"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_TRUE(cli.help_requested());
  const std::string help = cli.Help();
  EXPECT_NE(help.find("--markers FILE"), std::string::npos);
  EXPECT_NE(help.find("[default: 1.5]"), std::string::npos);
}

TEST(CommandLine, ParseOrPrintHelpTellsWhetherToRun) {
  Argv help({"cmd", "--help"});
  CommandLine a = MakeCli();
  ::testing::internal::CaptureStdout();
  EXPECT_FALSE(a.ParseOrPrintHelp(help.argc(), help.argv(), 1));
  EXPECT_NE(::testing::internal::GetCapturedStdout().find("--markers FILE"), std::string::npos);
  Argv run({"cmd", "--markers", "in.csv"});
  CommandLine b = MakeCli();
  EXPECT_TRUE(b.ParseOrPrintHelp(run.argc(), run.argv(), 1));
  Argv bad({"cmd"});
  CommandLine c = MakeCli();
  EXPECT_THROW(c.ParseOrPrintHelp(bad.argc(), bad.argv(), 1), InputError);
}

TEST(CommandLine, UnknownOptionIsReportedBeforeTheMissingRequiredOne) {
  // a misspelt required option: its name is the useful message
  ExpectInputError({"cmd", "--marker", "a"}, "unknown option --marker (see --help)");
  ExpectInputError({"cmd", "--markers", "a", "--bogus=1"}, "unknown option --bogus (see --help)");
}

TEST(CommandLine, LastValueWinsAndNegativeNumbersAreValues) {
  Argv a({"cmd", "--markers", "a", "--rate", "-2.5", "--markers", "b"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_EQ(cli.GetString("markers"), "b");
  EXPECT_DOUBLE_EQ(cli.GetDouble("rate"), -2.5);
}

TEST(CommandLine, GivenTellsTheCommandLineFromTheDefault) {
  Argv a({"cmd", "--markers=in.csv"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_TRUE(cli.Given("markers"));
  EXPECT_FALSE(cli.Given("rate"));  // defaulted: a scenario value would stay
  EXPECT_TRUE(cli.Has("rate"));
  EXPECT_FALSE(cli.Given("quiet"));
  Argv b({"cmd", "--markers", "in.csv", "--rate", "1.5", "--quiet"});
  CommandLine given = MakeCli();
  given.Parse(b.argc(), b.argv(), 1);
  EXPECT_TRUE(given.Given("rate"));  // given, even with the default's value
  EXPECT_TRUE(given.Given("quiet"));
}

TEST(CommandLine, FlagsCount) {
  Argv a({"cmd", "--markers", "a", "--quiet", "--quiet"});
  CommandLine cli = MakeCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_EQ(cli.GetCount("quiet"), 2);
  EXPECT_TRUE(cli.GetFlag("quiet"));
}

// Typed options: the value is checked when parsing, before any Get.
CommandLine MakeTypedCli() {
  CommandLine cli("prog cmd", "typed");
  cli.Choice("mode", "MODE", "how to run", {"realtime", "lockstep"}, "realtime")
      .Number("gain", "K", "control gain", "0.1", 0.0, 1.0)
      .Number("offset", "M", "any offset (m)")
      .Integer("domain", "N", "DDS domain id", "0", 0, 232)
      .Integer("seed", "N", "random seed", "1", 0)
      .Integer("steps", "N", "step count");
  return cli;
}

void ExpectTypedError(std::vector<std::string> args, const std::string& message) {
  Argv a(std::move(args));
  CommandLine cli = MakeTypedCli();
  try {
    cli.Parse(a.argc(), a.argv(), 1);
    FAIL() << "expected InputError '" << message << "'";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
}

TEST(CommandLine, TypedOptionsReadTheirValues) {
  Argv a({"cmd", "--mode", "lockstep", "--gain=0.5", "--offset", "-0.25", "--domain", "7",
          "--steps", "-3"});
  CommandLine cli = MakeTypedCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_EQ(cli.GetString("mode"), "lockstep");
  EXPECT_DOUBLE_EQ(cli.GetDouble("gain"), 0.5);
  EXPECT_DOUBLE_EQ(cli.GetDouble("offset"), -0.25);
  EXPECT_EQ(cli.GetInt("domain"), 7);
  EXPECT_EQ(cli.GetInt("seed"), 1);  // the default
  EXPECT_EQ(cli.GetInt("steps"), -3);
  Argv none({"cmd"});
  CommandLine defaults = MakeTypedCli();
  defaults.Parse(none.argc(), none.argv(), 1);
  EXPECT_EQ(defaults.GetString("mode"), "realtime");
  EXPECT_FALSE(defaults.Has("offset"));
  EXPECT_FALSE(defaults.Given("mode"));
}

TEST(CommandLine, TypedOptionsRejectBadValuesWhenParsing) {
  ExpectTypedError({"cmd", "--mode", "fast"},
                   "--mode: expected one of realtime, lockstep, got 'fast'");
  ExpectTypedError({"cmd", "--gain", "high"}, "--gain: expected a finite number, got 'high'");
  ExpectTypedError({"cmd", "--gain", "inf"}, "--gain: expected a finite number, got 'inf'");
  ExpectTypedError({"cmd", "--gain", "2"}, "--gain: expected a number in [0, 1], got 2");
  ExpectTypedError({"cmd", "--domain", "x"}, "--domain: expected an integer, got 'x'");
  ExpectTypedError({"cmd", "--domain", "1.5"}, "--domain: expected an integer, got '1.5'");
  ExpectTypedError({"cmd", "--domain", "999"},
                   "--domain: expected an integer in [0, 232], got 999");
  ExpectTypedError({"cmd", "--seed", "-1"}, "--seed: expected an integer >= 0, got -1");
  ExpectTypedError({"cmd", "--steps"}, "option --steps expects a value N");
}

TEST(CommandLine, HelpWinsOverABadValue) {
  Argv a({"cmd", "--mode", "fast", "--help"});
  CommandLine cli = MakeTypedCli();
  cli.Parse(a.argc(), a.argv(), 1);
  EXPECT_TRUE(cli.help_requested());
}

TEST(CommandLine, HelpHasTheUsageTheSummaryAndEveryOption) {
  const std::string help = MakeCli().Help();
  EXPECT_EQ(help.rfind("usage: prog cmd\n\ntest\n", 0), 0u) << help;
  EXPECT_NE(help.find("--markers FILE"), std::string::npos) << help;
  EXPECT_NE(help.find("input (required)"), std::string::npos) << help;
  EXPECT_NE(help.find("--rate X"), std::string::npos) << help;
  EXPECT_NE(help.find("rate [default: 1.5]"), std::string::npos) << help;
  EXPECT_NE(help.find("--quiet"), std::string::npos) << help;
  EXPECT_NE(help.find("--help"), std::string::npos) << help;
  const std::string typed = MakeTypedCli().Help();
  EXPECT_NE(typed.find("--mode MODE"), std::string::npos) << typed;
  EXPECT_NE(typed.find("how to run (one of: realtime, lockstep) [default: realtime]"),
            std::string::npos)
      << typed;
}

TEST(RunSubcommands, ExitCodesFollowTheConvention) {
  std::vector<Subcommand> cmds = {
      {"ok", "", [](int, char**) { return 0; }},
      {"bad", "", [](int, char**) -> int { throw InputError("bad value"); }},
      {"boom", "", [](int, char**) -> int { throw std::runtime_error("solver diverged"); }}};
  for (auto [name, code] :
       std::vector<std::pair<std::string, int>>{{"ok", 0}, {"bad", 2}, {"boom", 1}, {"nope", 2}}) {
    Argv a({"prog", name});
    EXPECT_EQ(RunSubcommands("prog", "", cmds, a.argc(), a.argv()), code) << name;
  }
  Argv none({"prog"});
  EXPECT_EQ(RunSubcommands("prog", "", cmds, none.argc(), none.argv()), 2);
}

}  // namespace
}  // namespace nsim
