#pragma once
// The marker-stream CSV format (DESIGN.md "Formats"):
//   t,m0_x,m0_y,m0_z,m1_x,m1_y,m1_z,...
// one row per frame; t in seconds, strictly increasing; positions in metres, world frame.
// Reading validates the header, the column count, the time order and that every value is a
// finite number; errors name the source, the line and the column.

#include <fstream>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "common/core/line_file.h"
#include "common/core/samples.h"

namespace nsim {

/// A recorded marker stream. frames[k].stamp.seq == k and stamp.sim_time is the row's t.
struct MarkerStream {
  int num_markers = 0;
  std::vector<MarkerFrame> frames;
};

/// Reads and validates a marker CSV file. Throws InputError "FILE:LINE:COLUMN: ...".
MarkerStream ReadMarkerCsv(const std::string& path);

/// Same, from a stream; `source` names it in error messages.
MarkerStream ParseMarkerCsv(std::istream& in, const std::string& source);

/// The most markers a marker CSV may have (a SensorFrame carries at most 64, `direct_sim
/// breathe` writes up to 100): a wider header is refused before any row is read.
constexpr int kMaxCsvMarkers = 1000;

/// Checks that the stream's time column is a plausible, roughly uniform sampling: InputError
/// "<source>:<line>:1 (t): ..." naming the row that ends the first interval longer than
/// `max_ratio` times the median interval or longer than `max_gap_s` seconds (pass infinity
/// to skip that test). A stream of fewer than 2 frames has no interval and passes.
void CheckMarkerSampling(const MarkerStream& stream, const std::string& source, double max_ratio,
                         double max_gap_s);

/// The header line for `num_markers` markers (no newline).
std::string MarkerCsvHeader(int num_markers);

/// Writes frames one by one, each row with one write of the complete line, so a recording
/// killed at any point holds whole rows only. Writing to a path goes to "<path>.partial" until
/// Close() renames it onto `path` (common/core/line_file.h): a recording that never finishes
/// leaves an earlier file at `path` untouched. Values are written with 17 significant digits:
/// reading them back gives the same doubles.
class MarkerCsvWriter {
 public:
  /// Creates "<path>.partial" and writes the header. Throws InputError if it cannot.
  MarkerCsvWriter(const std::string& path, int num_markers);
  /// Writes to a caller-owned stream (tests).
  MarkerCsvWriter(std::ostream& out, int num_markers);

  /// Appends one row. Throws InputError if the frame's marker count differs from the header's
  /// or its time does not increase.
  void Write(const MarkerFrame& frame);
  /// Renames the partial file onto the path (a file writer; a no-op on a stream).
  void Close();
  int num_markers() const { return num_markers_; }
  long rows_written() const { return rows_; }

 private:
  void WriteLine(const std::string& line);

  std::unique_ptr<LineFile> file_;
  std::ostream* out_ = nullptr;
  std::string path_;
  int num_markers_;
  long rows_ = 0;
  double last_t_ = 0.0;
};

/// Writes a whole stream to `path`.
void WriteMarkerCsv(const std::string& path, const MarkerStream& stream);

}  // namespace nsim
