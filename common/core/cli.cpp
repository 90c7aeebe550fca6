#include "common/core/cli.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>

#include "common/core/error.h"

namespace nsim {
namespace {

// A value's check: what is wrong with the text, "" when it passes. CLI11 prefixes the text with
// the option ("--rate: ...").
using Check = std::function<std::string(const std::string& text)>;

std::string NumberProblem(const std::string& text, double* value) {
  errno = 0;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE ||
      !std::isfinite(*value))
    return Str("expected a finite number, got '", text, "'");
  return "";
}

std::string IntegerProblem(const std::string& text, long* value) {
  errno = 0;
  char* end = nullptr;
  *value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    return Str("expected an integer, got '", text, "'");
  return "";
}

// "in [lo, hi]", ">= lo" or "<= hi" for the bounds that are not the type's own limits
template <typename T>
std::string RangeText(T lo, T hi, T lowest, T highest) {
  if (lo != lowest && hi != highest) return Str("in [", lo, ", ", hi, "]");
  return lo != lowest ? Str(">= ", lo) : Str("<= ", hi);
}

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

// --help: the usage line and the summary, then one line per option (CLI11 lays out the rest)
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter(std::string usage, std::string summary)
      : usage_(std::move(usage)), summary_(std::move(summary)) {
    column_width(28);
  }
  std::string make_description(const CLI::App*) const override { return ""; }
  std::string make_usage(const CLI::App*, std::string) const override {
    return "usage: " + usage_ + "\n\n" + summary_ + "\n";
  }

 private:
  std::string usage_, summary_;
};

// The first argument no option took: an unknown option or a stray positional. It is reported
// before any other error, being the likely cause (a misspelt option leaves its value and the
// option it should have been behind).
void ThrowIfLeftOver(const std::vector<std::string>& left) {
  if (left.empty()) return;
  const std::string& arg = left.front();
  const bool looks_like_option = arg.size() > 1 && arg[0] == '-' && arg != "--" &&
                                 !std::isdigit(static_cast<unsigned char>(arg[1]));
  if (looks_like_option)
    throw InputError(Str("unknown option ", arg.substr(0, arg.find('=')), " (see --help)"));
  throw InputError(Str("unexpected argument '", arg, "'"));
}

}  // namespace

struct CommandLine::Impl {
  struct Declared {
    CLI::Option* option;
    std::string value_name, default_value;
    bool is_flag;
  };

  Impl(std::string usage, std::string summary) {
    app.formatter(std::make_shared<HelpFormatter>(std::move(usage), std::move(summary)));
    app.option_defaults()->group("options")->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    app.set_help_flag("-h,--help", "show this help");
    app.allow_extras();  // left-over arguments are reported by ThrowIfLeftOver
  }

  // Declares `--name VALUE`; the help line gets "(required)" and the default.
  void AddValue(const std::string& name, const std::string& value_name, std::string help,
                const std::string& default_value, bool required, const Check& check) {
    NSIM_CHECK(!declared.count(name), "option --", name, " declared twice");
    NSIM_CHECK(!check || default_value.empty() || check(default_value).empty(), "the default of --",
               name, ": ", check ? check(default_value) : "");
    if (required) help += " (required)";
    if (!default_value.empty()) help += " [default: " + default_value + "]";
    const std::string& text = help;  // const: a non-const string would be taken as the target
    CLI::Option* option = app.add_option("--" + name, text)->option_text(value_name);
    option->required(required);
    if (check)
      option->check(CLI::Validator([check](std::string& value) { return check(value); }, ""));
    declared[name] = {option, value_name, default_value, false};
    order.push_back(name);
  }

  const Declared& Get(const std::string& name) const {
    const auto it = declared.find(name);
    NSIM_CHECK(it != declared.end(), "option --", name, " was never declared");
    return it->second;
  }

  // The text of a CLI11 error, naming the option (CLI11's own texts are not all that clear).
  std::string Explain(const CLI::ParseError& error) const {
    if (dynamic_cast<const CLI::RequiredError*>(&error)) {
      for (const auto& name : order) {
        const Declared& d = declared.at(name);
        if (d.option->get_required() && d.option->count() == 0)
          return Str("missing required option --", name, " ", d.value_name);
      }
    }
    const std::string what = error.what();
    if (dynamic_cast<const CLI::ArgumentMismatch*>(&error)) {
      // a value missing after `--name` or a value given to a flag (`--name=1`); CLI11's text
      // begins with the option, "--name: " or (a flag) "name was given ..."
      const std::string said = what.rfind("--", 0) == 0 ? what.substr(2) : what;
      for (const auto& [name, d] : declared) {
        if (said.rfind(name, 0) != 0 || said.size() == name.size()) continue;
        if (said[name.size()] != ':' && said[name.size()] != ' ') continue;
        if (d.is_flag) return Str("option --", name, " takes no value");
        return Str("option --", name, " expects a value ", d.value_name);
      }
    }
    return what;  // a failed check: "--name: <what the check says>"
  }

  CLI::App app;
  std::map<std::string, Declared> declared;
  std::vector<std::string> order;  // of declaration
};

CommandLine::CommandLine(std::string usage, std::string summary)
    : impl_(std::make_unique<Impl>(std::move(usage), std::move(summary))) {}
CommandLine::CommandLine(CommandLine&&) noexcept = default;
CommandLine& CommandLine::operator=(CommandLine&&) noexcept = default;
CommandLine::~CommandLine() = default;

CommandLine& CommandLine::Option(const std::string& name, const std::string& value_name,
                                 const std::string& help, const std::string& default_value,
                                 bool required) {
  impl_->AddValue(name, value_name, help, default_value, required, nullptr);
  return *this;
}

CommandLine& CommandLine::Number(const std::string& name, const std::string& value_name,
                                 const std::string& help, const std::string& default_value,
                                 double min, double max, bool required) {
  NSIM_CHECK(min <= max, "--", name, ": empty range");
  const double lowest = -std::numeric_limits<double>::infinity(), highest = -lowest;
  const Check check = [=](const std::string& text) -> std::string {
    double v;
    if (std::string problem = NumberProblem(text, &v); !problem.empty()) return problem;
    if (v < min || v > max)
      return Str("expected a number ", RangeText(min, max, lowest, highest), ", got ", text);
    return "";
  };
  impl_->AddValue(name, value_name, help, default_value, required, check);
  return *this;
}

CommandLine& CommandLine::Integer(const std::string& name, const std::string& value_name,
                                  const std::string& help, const std::string& default_value,
                                  long min, long max, bool required) {
  NSIM_CHECK(min <= max, "--", name, ": empty range");
  const long lowest = std::numeric_limits<long>::min(), highest = std::numeric_limits<long>::max();
  const Check check = [=](const std::string& text) -> std::string {
    long v;
    if (std::string problem = IntegerProblem(text, &v); !problem.empty()) return problem;
    if (v < min || v > max)
      return Str("expected an integer ", RangeText(min, max, lowest, highest), ", got ", text);
    return "";
  };
  impl_->AddValue(name, value_name, help, default_value, required, check);
  return *this;
}

CommandLine& CommandLine::Choice(const std::string& name, const std::string& value_name,
                                 const std::string& help, std::vector<std::string> choices,
                                 const std::string& default_value, bool required) {
  NSIM_CHECK(!choices.empty(), "--", name, ": no choices");
  const std::string listed = Join(choices, ", ");
  const Check check = [choices = std::move(choices), listed](const std::string& text) {
    if (std::find(choices.begin(), choices.end(), text) != choices.end()) return std::string();
    return Str("expected one of ", listed, ", got '", text, "'");
  };
  impl_->AddValue(name, value_name, help + " (one of: " + listed + ")", default_value, required,
                  check);
  return *this;
}

CommandLine& CommandLine::Flag(const std::string& name, const std::string& help) {
  NSIM_CHECK(!impl_->declared.count(name), "option --", name, " declared twice");
  // no `--name=value`: a flag's value would be silently read as true or false
  CLI::Option* option = impl_->app.add_flag("--" + name, help)->disable_flag_override();
  impl_->declared[name] = {option, "", "", true};
  impl_->order.push_back(name);
  return *this;
}

void CommandLine::Parse(int argc, char** argv, int first) {
  std::vector<std::string> args(argv + std::min(first, argc), argv + argc);
  std::reverse(args.begin(), args.end());  // CLI11 takes them from the back
  CLI::App& app = impl_->app;
  try {
    app.parse(args);
  } catch (const CLI::CallForHelp&) {
    help_ = true;
    return;
  } catch (const CLI::ParseError& e) {
    // --help wins over a bad value or a missing option (CLI11 checks values before --help)
    if (app.get_help_ptr()->count() > 0) {
      help_ = true;
      return;
    }
    ThrowIfLeftOver(app.remaining());
    throw InputError(impl_->Explain(e));
  }
  ThrowIfLeftOver(app.remaining());
}

bool CommandLine::ParseOrPrintHelp(int argc, char** argv, int first) {
  Parse(argc, argv, first);
  if (help_) std::cout << Help();
  return !help_;
}

std::string CommandLine::Help() const { return impl_->app.help(); }

bool CommandLine::Has(const std::string& name) const {
  return Given(name) || !impl_->Get(name).default_value.empty();
}

bool CommandLine::Given(const std::string& name) const {
  return impl_->Get(name).option->count() > 0;
}

std::string CommandLine::GetString(const std::string& name) const {
  const Impl::Declared& d = impl_->Get(name);
  return d.option->count() > 0 ? d.option->as<std::string>() : d.default_value;
}

double CommandLine::GetDouble(const std::string& name) const {
  return ParseDouble(GetString(name), "--" + name);
}

long CommandLine::GetInt(const std::string& name) const {
  return ParseInt(GetString(name), "--" + name);
}

bool CommandLine::GetFlag(const std::string& name) const { return GetCount(name) > 0; }

int CommandLine::GetCount(const std::string& name) const {
  const Impl::Declared& d = impl_->Get(name);
  NSIM_CHECK(d.is_flag, "--", name, " is not a flag");
  return static_cast<int>(d.option->count());
}

double ParseDouble(const std::string& text, const std::string& what) {
  double v;
  if (std::string problem = NumberProblem(text, &v); !problem.empty())
    throw InputError(Str(what, ": ", problem));
  return v;
}

long ParseInt(const std::string& text, const std::string& what) {
  long v;
  if (std::string problem = IntegerProblem(text, &v); !problem.empty())
    throw InputError(Str(what, ": ", problem));
  return v;
}

int RunSubcommands(const std::string& program, const std::string& summary,
                   const std::vector<Subcommand>& subcommands, int argc, char** argv) {
  auto usage = [&](std::ostream& out) {
    out << "usage: " << program << " <command> [options]\n\n" << summary << "\n\ncommands:\n";
    for (const auto& c : subcommands) {
      std::string left = "  " + c.name;
      out << left << std::string(left.size() < 16 ? 16 - left.size() : 1, ' ') << c.summary << "\n";
    }
    out << "\nRun '" << program << " <command> --help' for the options of a command.\n";
  };
  if (argc < 2) {
    usage(std::cerr);
    return 2;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    usage(std::cout);
    return 0;
  }
  for (const auto& c : subcommands) {
    if (c.name != name) continue;
    try {
      return c.run(argc - 1, argv + 1);
    } catch (const InputError& e) {
      std::cerr << program << " " << name << ": error: " << e.what() << "\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << program << " " << name << ": failure: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << program << ": unknown command '" << name << "'\n\n";
  usage(std::cerr);
  return 2;
}

}  // namespace nsim
