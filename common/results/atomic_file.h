#pragma once
// Results written so that a reader never sees half a file: the text goes to a temporary file
// in the same folder, is flushed to disk, and replaces the target by rename(2), which is atomic
// on POSIX file systems. A run killed while writing leaves the previous file intact.

#include <string>

namespace nsim {

/// Writes `text` to `path` atomically. Throws std::runtime_error naming the path on failure.
void WriteFileAtomically(const std::string& path, const std::string& text);

}  // namespace nsim
