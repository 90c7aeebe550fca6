#pragma once
// Range checks of physical values read from configs and command lines (DESIGN.md "Bad input
// and faults"): every value has a lower and an upper bound with a physical argument next to
// the call, so an absurd value (a gravity of 1e6 m/s^2, a time step of 1e-9 s) is an
// InputError naming the key instead of a run that never ends or ends in garbage.

#include <cmath>
#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "common/core/error.h"

namespace nsim {

/// Throws InputError "<key> must be in [lo, hi] (<unit>), got <v>" unless lo <= v <= hi; with
/// `open_low`, "(lo, hi]" and lo < v. NaN always fails. `unit` may be empty.
inline void CheckRange(double v, double lo, double hi, const std::string& key,
                       const std::string& unit, bool open_low = false) {
  const bool ok = (open_low ? v > lo : v >= lo) && v <= hi;
  if (ok) return;
  throw InputError(Str(key, " must be in ", open_low ? "(" : "[", lo, ", ", hi, "]",
                       unit.empty() ? "" : " (" + unit + ")", ", got ", v));
}

/// CheckRange for a value that must be positive: (0, hi].
inline void CheckPositiveAtMost(double v, double hi, const std::string& key,
                                const std::string& unit) {
  CheckRange(v, 0.0, hi, key, unit, true);
}

/// The upper bound alone, for values whose lower bound is checked (and worded) elsewhere:
/// InputError "<key> must be <= <hi> (<unit>), got <v>". NaN fails.
inline void CheckAtMost(double v, double hi, const std::string& key, const std::string& unit) {
  if (v <= hi) return;
  throw InputError(
      Str(key, " must be <= ", hi, unit.empty() ? "" : " (" + unit + ")", ", got ", v));
}

/// Throws InputError "<key> must be finite with a norm of at most <max> (<unit>), got [...]".
inline void CheckNormAtMost(const Eigen::Vector3d& v, double max, const std::string& key,
                            const std::string& unit) {
  if (v.allFinite() && v.norm() <= max) return;
  throw InputError(Str(key, " must be finite with a norm of at most ", max, " (", unit,
                       "), got [", v.x(), ", ", v.y(), ", ", v.z(), "]"));
}

/// Throws InputError "<key> must be an integer in [lo, hi], got <v>".
inline void CheckCountRange(long long v, long long lo, long long hi, const std::string& key) {
  if (v >= lo && v <= hi) return;
  throw InputError(Str(key, " must be an integer in [", lo, ", ", hi, "], got ", v));
}

/// The longest DDS partition name accepted (characters).
constexpr size_t kMaxPartitionLength = 64;

/// Throws InputError "<key> must be 1..<max> characters of [A-Za-z0-9_-], got ..." (the text
/// shown shortened) unless `text` is such a name. DDS partitions are names, not free text:
/// Cyclone crashed on a 65,535-character partition, and '*' or '?' are wildcards there.
inline void CheckName(const std::string& text, size_t max_length, const std::string& key) {
  bool ok = !text.empty() && text.size() <= max_length;
  for (const char c : text)
    ok = ok && ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                c == '_' || c == '-');
  if (ok) return;
  const std::string shown = text.size() > 40 ? text.substr(0, 40) + "..." : text;
  throw InputError(Str(key, " must be 1..", max_length, " characters of [A-Za-z0-9_-], got '",
                       shown, "' (", text.size(), " characters)"));
}

}  // namespace nsim
