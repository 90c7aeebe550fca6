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

/// The header line for `num_markers` markers (no newline).
std::string MarkerCsvHeader(int num_markers);

/// Writes frames one by one, flushing each row, so a recording survives a crash of its writer.
/// Values are written with 17 significant digits: reading them back gives the same doubles.
class MarkerCsvWriter {
 public:
  /// Opens (truncates) `path` and writes the header. Throws InputError if it cannot.
  MarkerCsvWriter(const std::string& path, int num_markers);
  /// Writes to a caller-owned stream (tests).
  MarkerCsvWriter(std::ostream& out, int num_markers);

  /// Appends one row. Throws InputError if the frame's marker count differs from the header's
  /// or its time does not increase.
  void Write(const MarkerFrame& frame);
  int num_markers() const { return num_markers_; }
  long rows_written() const { return rows_; }

 private:
  std::unique_ptr<std::ofstream> file_;
  std::ostream* out_;
  std::string path_;
  int num_markers_;
  long rows_ = 0;
  double last_t_ = 0.0;
};

/// Writes a whole stream to `path`.
void WriteMarkerCsv(const std::string& path, const MarkerStream& stream);

}  // namespace nsim
