#pragma once
// A CSV (or any line-based) results file that a kill cannot leave with half a row, and that a
// new run does not truncate before it has finished: lines go to "<path>.partial", each with a
// single write(2) of the complete line (no user-space buffer that a kill would leave half
// written), and Commit() renames the partial file onto <path> (atomic on POSIX file systems).
// A run killed before Commit() leaves the earlier <path> intact and its own rows, whole, in
// <path>.partial.

#include <string>

namespace nsim {

class LineFile {
 public:
  /// Creates (truncates) "<path>.partial". InputError naming it when it cannot.
  explicit LineFile(const std::string& path);
  /// Closes the descriptor; an uncommitted file stays as "<path>.partial".
  ~LineFile();
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;

  /// Appends `line` and a newline with one write; std::runtime_error naming the file when the
  /// write fails (disk full).
  void WriteLine(const std::string& line);
  /// Closes the file and renames it onto path(); later calls do nothing.
  /// std::runtime_error naming it when the rename fails.
  void Commit();

  const std::string& path() const { return path_; }
  std::string partial_path() const { return path_ + ".partial"; }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace nsim
