#pragma once
// A CSV (or any line-based) results file that a kill cannot leave with half a row: each line
// is one write(2) of the complete line (no user-space buffer that a kill would leave half
// written). Two modes:
// - kPartial: lines go to "<path>.partial" and Commit() renames it onto <path> (atomic on
//   POSIX file systems); a run killed before Commit() leaves an earlier <path> intact and its
//   own rows, whole, in <path>.partial (recordings: inverse_sim record's OUT.csv).
// - kInPlace: lines go to <path> itself, readable while the run goes on (a run's
//   timeseries.csv is watched live: tests/integration/closed_loop_test.cpp); Commit() only
//   flushes and closes.

#include <string>

namespace nsim {

class LineFile {
 public:
  enum class Mode { kPartial, kInPlace };

  /// Creates (truncates) "<path>.partial" (kPartial) or <path> (kInPlace). InputError naming
  /// the file when it cannot.
  explicit LineFile(const std::string& path, Mode mode = Mode::kPartial);
  /// Closes the descriptor; an uncommitted file stays as "<path>.partial".
  ~LineFile();
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;

  /// Appends `line` and a newline with one write; std::runtime_error naming the file when the
  /// write fails (disk full).
  void WriteLine(const std::string& line);
  /// Closes the file and (kPartial) renames it onto path(); later calls do nothing.
  /// std::runtime_error naming it when the rename fails.
  void Commit();

  const std::string& path() const { return path_; }
  /// The file being written: "<path>.partial" or the path itself.
  std::string partial_path() const {
    return mode_ == Mode::kPartial ? path_ + ".partial" : path_;
  }

 private:
  std::string path_;
  Mode mode_;
  int fd_ = -1;
};

}  // namespace nsim
