#include "common/markers/marker_csv.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <ostream>
#include <sstream>

#include "common/core/error.h"
#include "common/core/input_file.h"

namespace nsim {
namespace {

std::vector<std::string> SplitCommas(const std::string& line) {
  std::vector<std::string> out;
  std::string::size_type start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    out.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::string ColumnName(int column) {  // 0-based column index
  if (column == 0) return "t";
  const int m = (column - 1) / 3;
  return Str("m", m, "_", "xyz"[(column - 1) % 3]);
}

}  // namespace

std::string MarkerCsvHeader(int num_markers) {
  std::string header = "t";
  for (int c = 1; c <= 3 * num_markers; ++c) header += "," + ColumnName(c);
  return header;
}

MarkerStream ParseMarkerCsv(std::istream& in, const std::string& source) {
  auto fail = [&](long line, int column, const std::string& what) -> InputError {
    if (column < 0) return InputError(Str(source, ":", line, ": ", what));
    return InputError(
        Str(source, ":", line, ":", column + 1, " (", ColumnName(column), "): ", what));
  };
  MarkerStream stream;
  std::string line;
  long line_no = 0;
  if (!std::getline(in, line))
    throw fail(1, -1, "empty file: expected the header 't,m0_x,m0_y,m0_z,...'");
  ++line_no;
  const std::vector<std::string> header = SplitCommas(Trim(line));
  if (header.size() > 1 + 3 * static_cast<size_t>(kMaxCsvMarkers))
    throw fail(line_no, -1,
               Str("header has ", header.size(), " columns; at most ", kMaxCsvMarkers,
                   " markers (", 1 + 3 * kMaxCsvMarkers, " columns) are read"));
  if (header.size() < 4 || (header.size() - 1) % 3 != 0)
    throw fail(line_no, -1,
               Str("header has ", header.size(),
                   " columns; expected 1 + 3 per marker ('t,m0_x,m0_y,m0_z,...')"));
  for (size_t c = 0; c < header.size(); ++c) {
    if (Trim(header[c]) != ColumnName(static_cast<int>(c)))
      throw fail(line_no, static_cast<int>(c),
                 Str("header: expected '", ColumnName(static_cast<int>(c)), "', got '",
                     Trim(header[c]), "'"));
  }
  stream.num_markers = static_cast<int>((header.size() - 1) / 3);

  bool saw_blank = false;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string row = Trim(line);
    if (row.empty()) {
      saw_blank = true;
      continue;
    }
    if (saw_blank) throw fail(line_no - 1, -1, "blank line inside the data");
    const std::vector<std::string> cells = SplitCommas(row);
    if (cells.size() != header.size())
      throw fail(line_no, -1, Str("expected ", header.size(), " columns, got ", cells.size()));
    std::vector<double> v(cells.size());
    for (size_t c = 0; c < cells.size(); ++c) {
      const std::string cell = Trim(cells[c]);
      errno = 0;
      char* end = nullptr;
      v[c] = std::strtod(cell.c_str(), &end);
      if (cell.empty() || end != cell.c_str() + cell.size())
        throw fail(line_no, static_cast<int>(c), Str("expected a number, got '", cell, "'"));
      if (!std::isfinite(v[c]) || errno == ERANGE)
        throw fail(line_no, static_cast<int>(c), Str("expected a finite value, got '", cell, "'"));
    }
    if (!stream.frames.empty() && !(v[0] > stream.frames.back().stamp.sim_time))
      throw fail(line_no, 0,
                 Str("time must increase strictly: ", v[0], " after ",
                     stream.frames.back().stamp.sim_time));
    MarkerFrame frame;
    frame.stamp.seq = stream.frames.size();
    frame.stamp.sim_time = v[0];
    frame.p_WM.resize(stream.num_markers);
    for (int m = 0; m < stream.num_markers; ++m)
      frame.p_WM[m] = Eigen::Vector3d(v[1 + 3 * m], v[2 + 3 * m], v[3 + 3 * m]);
    stream.frames.push_back(std::move(frame));
  }
  if (stream.frames.empty()) throw fail(line_no, -1, "no data rows after the header");
  return stream;
}

void CheckMarkerSampling(const MarkerStream& stream, const std::string& source, double max_ratio,
                         double max_gap_s) {
  const auto& frames = stream.frames;
  if (frames.size() < 2) return;
  std::vector<double> dt(frames.size() - 1);
  for (size_t k = 1; k < frames.size(); ++k)
    dt[k - 1] = frames[k].stamp.sim_time - frames[k - 1].stamp.sim_time;
  std::vector<double> sorted = dt;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (size_t k = 1; k < frames.size(); ++k) {
    const double gap = dt[k - 1];
    // rows are consecutive lines after the header: frame k is on line k + 2
    const long line = static_cast<long>(k) + 2;
    if (gap > max_gap_s)
      throw InputError(Str(source, ":", line, ":1 (t): a gap of ", gap, " s after t = ",
                           frames[k - 1].stamp.sim_time, " s, more than the ", max_gap_s,
                           " s allowed between two frames"));
    if (gap > max_ratio * median)
      throw InputError(Str(source, ":", line, ":1 (t): a gap of ", gap, " s after t = ",
                           frames[k - 1].stamp.sim_time, " s, more than ", max_ratio,
                           " times the median frame interval (", median,
                           " s): not a uniform sampling"));
  }
}

MarkerStream ReadMarkerCsv(const std::string& path) {
  std::istringstream in(ReadInputFile(path, "marker CSV"));
  return ParseMarkerCsv(in, path);
}

MarkerCsvWriter::MarkerCsvWriter(const std::string& path, int num_markers)
    : path_(path), num_markers_(num_markers) {
  if (num_markers < 1) throw InputError(Str(path, ": a marker stream needs at least one marker"));
  file_ = std::make_unique<LineFile>(path);
  WriteLine(MarkerCsvHeader(num_markers));
}

MarkerCsvWriter::MarkerCsvWriter(std::ostream& out, int num_markers)
    : out_(&out), path_("<stream>"), num_markers_(num_markers) {
  NSIM_CHECK(num_markers >= 1, "num_markers ", num_markers);
  *out_ << MarkerCsvHeader(num_markers) << "\n";
}

void MarkerCsvWriter::Write(const MarkerFrame& frame) {
  if (static_cast<int>(frame.p_WM.size()) != num_markers_)
    throw InputError(Str(path_, ": frame ", frame.stamp.seq, " has ", frame.p_WM.size(),
                         " markers, the header has ", num_markers_));
  if (rows_ > 0 && !(frame.stamp.sim_time > last_t_))
    throw InputError(Str(path_, ": frame ", frame.stamp.seq, " time ", frame.stamp.sim_time,
                         " does not increase (last ", last_t_, ")"));
  // the whole row in one string, written at once: a kill leaves no half row
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", frame.stamp.sim_time);
  std::string line = buf;
  for (const auto& p : frame.p_WM) {
    for (int k = 0; k < 3; ++k) {
      std::snprintf(buf, sizeof buf, ",%.17g", p[k]);
      line += buf;
    }
  }
  WriteLine(line);
  last_t_ = frame.stamp.sim_time;
  ++rows_;
}

void MarkerCsvWriter::WriteLine(const std::string& line) {
  if (file_) {
    file_->WriteLine(line);
    return;
  }
  const std::string text = line + "\n";
  out_->write(text.data(), static_cast<std::streamsize>(text.size()));
  out_->flush();
  if (!*out_) throw std::runtime_error(Str(path_, ": write failed"));
}

void MarkerCsvWriter::Close() {
  if (file_) file_->Commit();
}

void WriteMarkerCsv(const std::string& path, const MarkerStream& stream) {
  MarkerCsvWriter writer(path, stream.num_markers);
  for (const auto& f : stream.frames) writer.Write(f);
  writer.Close();
}

}  // namespace nsim
