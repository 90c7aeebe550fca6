#include "common/core/cli.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "common/core/error.h"

namespace nsim {

CommandLine::CommandLine(std::string usage, std::string summary)
    : usage_(std::move(usage)), summary_(std::move(summary)) {}

CommandLine& CommandLine::Option(const std::string& name, const std::string& value_name,
                                 const std::string& help, const std::string& default_value,
                                 bool required) {
  order_.push_back(name);
  specs_[name] = Spec{value_name, help, default_value, false, required};
  return *this;
}

CommandLine& CommandLine::Flag(const std::string& name, const std::string& help) {
  order_.push_back(name);
  specs_[name] = Spec{"", help, "", true, false};
  return *this;
}

void CommandLine::Parse(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      help_ = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) throw InputError(Str("unexpected argument '", arg, "'"));
    std::string name = arg.substr(2), value;
    bool inline_value = false;
    if (const auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
      inline_value = true;
    }
    const auto it = specs_.find(name);
    if (it == specs_.end()) throw InputError(Str("unknown option --", name, " (see --help)"));
    if (it->second.is_flag) {
      if (inline_value) throw InputError(Str("option --", name, " takes no value"));
      values_[name] = "1";
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argc)
        throw InputError(Str("option --", name, " expects a value ", it->second.value_name));
      value = argv[++i];
    }
    values_[name] = value;
  }
  if (help_) return;
  for (const auto& [name, spec] : specs_) {
    if (spec.required && !values_.count(name))
      throw InputError(Str("missing required option --", name, " ", spec.value_name));
  }
}

bool CommandLine::ParseOrPrintHelp(int argc, char** argv, int first) {
  Parse(argc, argv, first);
  if (help_) std::cout << Help();
  return !help_;
}

std::string CommandLine::Help() const {
  std::ostringstream out;
  out << "usage: " << usage_ << "\n\n" << summary_ << "\n\noptions:\n";
  for (const auto& name : order_) {
    const Spec& s = specs_.at(name);
    std::string left = "  --" + name + (s.is_flag ? "" : " " + s.value_name);
    out << left;
    if (left.size() < 28)
      out << std::string(28 - left.size(), ' ');
    else
      out << "\n" << std::string(28, ' ');
    out << s.help;
    if (s.required) out << " (required)";
    if (!s.default_value.empty()) out << " [default: " << s.default_value << "]";
    out << "\n";
  }
  out << "  --help                    show this help\n";
  return out.str();
}

bool CommandLine::Has(const std::string& name) const {
  NSIM_CHECK(specs_.count(name), "option --", name, " was never declared");
  return values_.count(name) || !specs_.at(name).default_value.empty();
}

std::string CommandLine::GetString(const std::string& name) const {
  NSIM_CHECK(specs_.count(name), "option --", name, " was never declared");
  const auto it = values_.find(name);
  return it != values_.end() ? it->second : specs_.at(name).default_value;
}

double CommandLine::GetDouble(const std::string& name) const {
  return ParseDouble(GetString(name), "--" + name);
}

long CommandLine::GetInt(const std::string& name) const {
  return ParseInt(GetString(name), "--" + name);
}

bool CommandLine::GetFlag(const std::string& name) const {
  NSIM_CHECK(specs_.count(name) && specs_.at(name).is_flag, "--", name, " is not a flag");
  return values_.count(name) > 0;
}

double ParseDouble(const std::string& text, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
    throw InputError(Str(what, ": expected a finite number, got '", text, "'"));
  return v;
}

long ParseInt(const std::string& text, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw InputError(Str(what, ": expected an integer, got '", text, "'"));
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
