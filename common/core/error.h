#pragma once
// Error tiers (STYLE.md): InputError for anything a user supplied (configs, files, messages,
// command lines): mains print it and exit with code 2. SolverError for a computation that
// failed on valid input (a diverged solve, a NaN the solver produced): a runtime failure, exit
// code 1. NSIM_CHECK for internal invariants: always on, aborts with file and line.

#include <sstream>
#include <stdexcept>
#include <string>

namespace nsim {

/// A problem with user input: a config key, a file, a message, a command-line flag.
/// The text says what was expected and what was found.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// A numerical failure on valid input: a solve that diverged or produced a non-finite value.
/// Not the user's fault; the run stops as a runtime failure (exit 1), reported as such.
class SolverError : public std::runtime_error {
 public:
  explicit SolverError(const std::string& what) : std::runtime_error(what) {}
};

/// Builds a message from streamable parts: Str("expected ", 3, " columns, got ", n).
template <typename... Parts>
std::string Str(const Parts&... parts) {
  std::ostringstream out;
  (out << ... << parts);
  return out.str();
}

[[noreturn]] void AbortCheck(const char* condition, const char* file, int line,
                             const std::string& message);

}  // namespace nsim

/// Always-on internal invariant; aborts with the condition, file and line.
#define NSIM_CHECK(condition, ...)                                                  \
  do {                                                                              \
    if (!(condition))                                                               \
      ::nsim::AbortCheck(#condition, __FILE__, __LINE__, ::nsim::Str(__VA_ARGS__)); \
  } while (0)
