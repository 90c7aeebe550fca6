#include "common/markers/marker_csv.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>

#include "common/core/error.h"

namespace nsim {
namespace {

MarkerStream RandomStream(int markers, int frames, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(-0.2, 0.2), dt(1e-4, 0.05);
  MarkerStream s;
  s.num_markers = markers;
  double t = -1.0;
  for (int k = 0; k < frames; ++k) {
    MarkerFrame f;
    f.stamp.seq = k;
    f.stamp.sim_time = t += dt(rng);
    for (int m = 0; m < markers; ++m) f.p_WM.emplace_back(pos(rng), pos(rng), pos(rng) * 1e-7);
    s.frames.push_back(f);
  }
  return s;
}

TEST(MarkerCsv, RoundTripIsExact) {
  const MarkerStream in = RandomStream(5, 200, 7);
  const std::string path =
      (std::filesystem::temp_directory_path() / "nsim_marker_roundtrip.csv").string();
  WriteMarkerCsv(path, in);
  const MarkerStream out = ReadMarkerCsv(path);
  ASSERT_EQ(out.num_markers, 5);
  ASSERT_EQ(out.frames.size(), in.frames.size());
  for (size_t k = 0; k < in.frames.size(); ++k) {
    EXPECT_EQ(out.frames[k].stamp.seq, k);
    EXPECT_EQ(out.frames[k].stamp.sim_time, in.frames[k].stamp.sim_time);  // bit-exact
    for (int m = 0; m < 5; ++m) EXPECT_EQ(out.frames[k].p_WM[m], in.frames[k].p_WM[m]);
  }
  std::remove(path.c_str());
}

TEST(MarkerCsv, HeaderNamesTheColumns) {
  EXPECT_EQ(MarkerCsvHeader(2), "t,m0_x,m0_y,m0_z,m1_x,m1_y,m1_z");
}

TEST(MarkerCsv, AcceptsCrlfAndSpacesAndTrailingBlankLines) {
  std::istringstream in("t, m0_x ,m0_y,m0_z\r\n0,1,2,3\r\n 0.5 ,4,5,6\r\n\n\n");
  const MarkerStream s = ParseMarkerCsv(in, "x.csv");
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_EQ(s.frames[1].p_WM[0], Eigen::Vector3d(4, 5, 6));
}

void ExpectError(const std::string& text, const std::string& fragment) {
  std::istringstream in(text);
  try {
    ParseMarkerCsv(in, "bad.csv");
    FAIL() << "expected an InputError containing '" << fragment << "' for:\n" << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
        << "message: " << e.what() << "\nexpected to contain: " << fragment;
  }
}

TEST(MarkerCsv, SamplingGapsNameTheLine) {
  std::istringstream in("t,m0_x,m0_y,m0_z\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n5.2,0,0,0\n5.3,0,0,0\n");
  const MarkerStream s = ParseMarkerCsv(in, "gap.csv");
  CheckMarkerSampling(s, "gap.csv", 100.0, 10.0);  // 50 x the median, 5 s: accepted
  try {
    CheckMarkerSampling(s, "gap.csv", 10.0, 10.0);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("gap.csv:5:1 (t): a gap of 5 s after t = 0.2 s, more "
                                          "than 10 times the median frame interval (0.1 s)",
                                          0),
              0u)
        << e.what();
  }
  try {
    CheckMarkerSampling(s, "gap.csv", 100.0, 1.0);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("gap.csv:5:1 (t): a gap of 5 s after t = 0.2 s, more "
                                          "than the 1 s allowed",
                                          0),
              0u)
        << e.what();
  }
}

TEST(MarkerCsv, HugeHeadersAndDevicesAreRefused) {
  std::string header = "t";
  for (int m = 0; m <= kMaxCsvMarkers; ++m) header += Str(",m", m, "_x,m", m, "_y,m", m, "_z");
  ExpectError(header + "\n", "bad.csv:1: header has 3004 columns; at most 1000 markers");
  try {
    ReadMarkerCsv("/dev/zero");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/dev/zero: expected a regular file as the marker CSV", 0),
              0u)
        << e.what();
  }
}

TEST(MarkerCsv, EveryMalformedCaseNamesFileLineAndColumn) {
  ExpectError("", "bad.csv:1: empty file");
  ExpectError("t,m0_x,m0_y\n0,1,2\n", "bad.csv:1: header has 3 columns");
  ExpectError("time,m0_x,m0_y,m0_z\n0,1,2,3\n",
              "bad.csv:1:1 (t): header: expected 't', got 'time'");
  ExpectError("t,m0_x,m0_z,m0_y\n0,1,2,3\n",
              "bad.csv:1:3 (m0_y): header: expected 'm0_y', got 'm0_z'");
  ExpectError("t,m0_x,m0_y,m0_z\n", "no data rows");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,2,3\n1,1,2\n", "bad.csv:3: expected 4 columns, got 3");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,2,3\n1,1,2,3,4\n", "bad.csv:3: expected 4 columns, got 5");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,abc,3\n", "bad.csv:2:3 (m0_y): expected a number, got 'abc'");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,,3\n", "bad.csv:2:3 (m0_y): expected a number, got ''");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,2,nan\n",
              "bad.csv:2:4 (m0_z): expected a finite value, got 'nan'");
  ExpectError("t,m0_x,m0_y,m0_z\n0,inf,2,3\n", "bad.csv:2:2 (m0_x): expected a finite value");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1e999,2,3\n", "bad.csv:2:2 (m0_x): expected a finite value");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,2,3\n0,1,2,3\n",
              "bad.csv:3:1 (t): time must increase strictly");
  ExpectError("t,m0_x,m0_y,m0_z\n1,1,2,3\n0.5,1,2,3\n",
              "bad.csv:3:1 (t): time must increase strictly");
  ExpectError("t,m0_x,m0_y,m0_z\n0,1,2,3\n\n1,1,2,3\n", "bad.csv:3: blank line inside the data");
  ExpectError("t,m0_x,m0_y,m0_z,m1_x,m1_y,m1_z\n0,1,2,3,4,5,6x\n",
              "bad.csv:2:7 (m1_z): expected a number, got '6x'");
}

TEST(MarkerCsv, MissingFileIsAnInputError) {
  EXPECT_THROW(ReadMarkerCsv("/nonexistent/dir/markers.csv"), InputError);
}

TEST(MarkerCsvWriter, RejectsInconsistentFrames) {
  std::ostringstream out;
  MarkerCsvWriter w(out, 2);
  MarkerFrame f;
  f.stamp.sim_time = 1.0;
  f.p_WM.assign(2, Eigen::Vector3d::Zero());
  w.Write(f);
  EXPECT_THROW(w.Write(f), InputError);  // same time again
  f.stamp.sim_time = 2.0;
  f.p_WM.resize(3);
  EXPECT_THROW(w.Write(f), InputError);  // wrong marker count
  EXPECT_EQ(w.rows_written(), 1);
}

}  // namespace
}  // namespace nsim
