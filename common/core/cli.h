#pragma once
// A small command-line layer for the two executables: subcommands, --options with values,
// --flags, generated --help, and the exit-code convention of DESIGN.md (0 success, 2 bad input
// or usage, 1 runtime failure). Parsing is done by CLI11, which only cli.cpp includes; every
// CLI11 error becomes an InputError that names the option.

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace nsim {

/// The options of one subcommand, one declaration per option: the declaration gives the value's
/// name, help text, default and check, and --help is generated from it. Values are kept as text
/// and converted on access, with errors that name the option.
class CommandLine {
 public:
  CommandLine(std::string usage, std::string summary);
  CommandLine(CommandLine&&) noexcept;
  CommandLine& operator=(CommandLine&&) noexcept;
  ~CommandLine();

  /// Declares `--name VALUE`; `default_value` empty and `required` false means optional.
  CommandLine& Option(const std::string& name, const std::string& value_name,
                      const std::string& help, const std::string& default_value = "",
                      bool required = false);
  /// Declares `--name VALUE` whose value must be a finite number in [min, max], checked when
  /// parsing: "--rate: expected a finite number, got 'fast'", "--rate: expected a number in
  /// [0, 10], got 12". Read it with GetDouble.
  CommandLine& Number(const std::string& name, const std::string& value_name,
                      const std::string& help, const std::string& default_value = "",
                      double min = -std::numeric_limits<double>::infinity(),
                      double max = std::numeric_limits<double>::infinity(), bool required = false);
  /// Declares `--name N` whose value must be an integer in [min, max], checked when parsing:
  /// "--domain: expected an integer, got 'x'". Read it with GetInt.
  CommandLine& Integer(const std::string& name, const std::string& value_name,
                       const std::string& help, const std::string& default_value = "",
                       long min = std::numeric_limits<long>::min(),
                       long max = std::numeric_limits<long>::max(), bool required = false);
  /// Declares `--name VALUE` whose value must be one of `choices`, checked when parsing:
  /// "--mode: expected one of realtime, lockstep, got 'fast'". The help lists the choices.
  CommandLine& Choice(const std::string& name, const std::string& value_name,
                      const std::string& help, std::vector<std::string> choices,
                      const std::string& default_value = "", bool required = false);
  /// Declares a boolean `--name`; it may be repeated (GetCount).
  CommandLine& Flag(const std::string& name, const std::string& help);

  /// Parses argv[first..argc). Throws InputError naming an unknown option, a missing value, a
  /// value that fails its check or a missing required option (unless --help was given). An
  /// option given twice keeps the last value.
  void Parse(int argc, char** argv, int first);

  /// Parse, and when --help was given prints Help() to stdout and returns false (the command
  /// then exits with 0); true when the command should run.
  bool ParseOrPrintHelp(int argc, char** argv, int first);

  bool help_requested() const { return help_; }
  std::string Help() const;

  bool Has(const std::string& name) const;  ///< given on the command line or defaulted
  /// Given on the command line (not defaulted): lets a command-line value override a value of
  /// a scenario file while the default does not.
  bool Given(const std::string& name) const;
  std::string GetString(const std::string& name) const;
  double GetDouble(const std::string& name) const;
  long GetInt(const std::string& name) const;
  bool GetFlag(const std::string& name) const;
  /// How many times the flag `--name` was given.
  int GetCount(const std::string& name) const;

 private:
  struct Impl;  // the CLI11 app and what each option was declared with
  std::unique_ptr<Impl> impl_;
  bool help_ = false;
};

/// Parses a number from text; throws InputError "<what>: expected a number, got '<text>'".
double ParseDouble(const std::string& text, const std::string& what);
long ParseInt(const std::string& text, const std::string& what);

/// One subcommand of an executable.
struct Subcommand {
  std::string name;
  std::string summary;
  std::function<int(int argc, char** argv)> run;  ///< argv[0] is the subcommand name
};

/// Dispatches argv[1] to a subcommand and applies the exit-code convention: InputError -> 2,
/// any other exception -> 1, both with a message on stderr prefixed by the program name.
int RunSubcommands(const std::string& program, const std::string& summary,
                   const std::vector<Subcommand>& subcommands, int argc, char** argv);

}  // namespace nsim
