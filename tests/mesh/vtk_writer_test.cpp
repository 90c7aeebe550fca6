#include "common/mesh/vtk_writer.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/core/error.h"
#include "common/mesh/tet_mesh.h"

namespace nsim {
namespace {

// minimal reader of what the writer produces: whitespace tokens with keyword checks
class Tokens {
 public:
  explicit Tokens(const std::string& text) {
    std::istringstream in(text);
    std::string line;
    for (int i = 0; i < 2 && std::getline(in, line); ++i)
      header_.push_back(line);  // version, title
    std::string t;
    while (in >> t) tokens_.push_back(t);
  }
  const std::vector<std::string>& header() const { return header_; }
  void Expect(const std::string& word) {
    ASSERT_LT(pos_, tokens_.size());
    EXPECT_EQ(tokens_[pos_++], word);
  }
  long Int() { return std::stol(tokens_.at(pos_++)); }
  double Real() { return std::stod(tokens_.at(pos_++)); }
  bool done() const { return pos_ == tokens_.size(); }

 private:
  std::vector<std::string> header_;
  std::vector<std::string> tokens_;
  size_t pos_ = 0;
};

TEST(VtkWriter, TetMeshRoundTrips) {
  const TetMesh mesh = MakeBoxTetMesh({3, 2, 2}, {0.3, 0.2, 0.1});
  Eigen::Matrix3Xd x = mesh.X;
  x.row(0) *= 1.0 / 3.0;  // values that need all 17 digits
  VtkData data;
  data.point_data.push_back({"temperature", Eigen::MatrixXd::Random(1, mesh.num_nodes())});
  data.point_data.push_back({"displacement_m", x - mesh.X});
  data.cell_data.push_back({"stress_Pa", Eigen::MatrixXd::Random(1, mesh.num_tets())});
  std::ostringstream out;
  WriteVtkTetMesh(out, mesh, x, data, "box state");
  Tokens r(out.str());
  ASSERT_EQ(r.header().size(), 2u);
  EXPECT_EQ(r.header()[0], "# vtk DataFile Version 3.0");
  EXPECT_EQ(r.header()[1], "box state");
  r.Expect("ASCII");
  r.Expect("DATASET");
  r.Expect("UNSTRUCTURED_GRID");
  r.Expect("POINTS");
  ASSERT_EQ(r.Int(), mesh.num_nodes());
  r.Expect("double");
  for (int i = 0; i < mesh.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.Real(), x(k, i));  // exact round trip
  r.Expect("CELLS");
  ASSERT_EQ(r.Int(), mesh.num_tets());
  EXPECT_EQ(r.Int(), 5 * mesh.num_tets());
  for (const auto& t : mesh.tets) {
    EXPECT_EQ(r.Int(), 4);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(r.Int(), t[k]);
  }
  r.Expect("CELL_TYPES");
  ASSERT_EQ(r.Int(), mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) EXPECT_EQ(r.Int(), 10);
  r.Expect("POINT_DATA");
  ASSERT_EQ(r.Int(), mesh.num_nodes());
  r.Expect("SCALARS");
  r.Expect("temperature");
  r.Expect("double");
  r.Expect("1");
  r.Expect("LOOKUP_TABLE");
  r.Expect("default");
  for (int i = 0; i < mesh.num_nodes(); ++i) EXPECT_EQ(r.Real(), data.point_data[0].values(0, i));
  r.Expect("VECTORS");
  r.Expect("displacement_m");
  r.Expect("double");
  for (int i = 0; i < mesh.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.Real(), data.point_data[1].values(k, i));
  r.Expect("CELL_DATA");
  ASSERT_EQ(r.Int(), mesh.num_tets());
  r.Expect("SCALARS");
  r.Expect("stress_Pa");
  r.Expect("double");
  r.Expect("1");
  r.Expect("LOOKUP_TABLE");
  r.Expect("default");
  for (int e = 0; e < mesh.num_tets(); ++e) EXPECT_EQ(r.Real(), data.cell_data[0].values(0, e));
  EXPECT_TRUE(r.done());
}

TEST(VtkWriter, SurfaceWritesOnlySurfaceNodes) {
  // 4 x 4 x 4 nodes: 8 interior nodes are left out
  const TetMesh mesh = MakeBoxTetMesh({4, 4, 4}, {1, 1, 1});
  VtkData data;
  Eigen::MatrixXd id(1, mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i) id(0, i) = i;
  data.point_data.push_back({"node_id", id});
  std::ostringstream out;
  WriteVtkSurface(out, mesh, mesh.X, data);
  Tokens r(out.str());
  r.Expect("ASCII");
  r.Expect("DATASET");
  r.Expect("POLYDATA");
  r.Expect("POINTS");
  const long n = r.Int();
  ASSERT_EQ(n, 64 - 8);
  r.Expect("double");
  Eigen::Matrix3Xd p(3, n);
  for (long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) p(k, i) = r.Real();
  r.Expect("POLYGONS");
  ASSERT_EQ(r.Int(), static_cast<long>(mesh.surface.size()));
  EXPECT_EQ(r.Int(), 4 * static_cast<long>(mesh.surface.size()));
  std::vector<Eigen::Vector3i> tris;
  for (size_t f = 0; f < mesh.surface.size(); ++f) {
    EXPECT_EQ(r.Int(), 3);
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) {
      t[k] = static_cast<int>(r.Int());
      ASSERT_GE(t[k], 0);
      ASSERT_LT(t[k], n);
    }
    tris.push_back(t);
  }
  r.Expect("POINT_DATA");
  ASSERT_EQ(r.Int(), n);
  for (const char* w : {"SCALARS", "node_id", "double", "1", "LOOKUP_TABLE", "default"})
    r.Expect(w);
  std::vector<int> ids(n);
  for (long i = 0; i < n; ++i) ids[i] = static_cast<int>(r.Real());
  EXPECT_TRUE(r.done());
  // the triangles, mapped back through the node ids, are the mesh's surface at the same places
  for (size_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(ids[tris[f][k]], mesh.surface[f][k]);
      EXPECT_EQ(p.col(tris[f][k]), mesh.X.col(mesh.surface[f][k]));
    }
}

TEST(VtkWriter, Polyline) {
  Eigen::Matrix3Xd needle(3, 4);
  needle << 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.01, 0.02, 0.03;
  VtkData data;
  data.cell_data.push_back({"inserted", Eigen::MatrixXd::Constant(1, 1, 1.0)});
  std::ostringstream out;
  WriteVtkPolyline(out, needle, data);
  Tokens r(out.str());
  for (const char* w : {"ASCII", "DATASET", "POLYDATA", "POINTS", "4", "double"}) r.Expect(w);
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.Real(), needle(k, i));
  for (const char* w : {"LINES", "1", "5", "4", "0", "1", "2", "3", "CELL_DATA", "1", "SCALARS",
                        "inserted", "double", "1", "LOOKUP_TABLE", "default", "1"})
    r.Expect(w);
  EXPECT_TRUE(r.done());
}

TEST(VtkWriter, FilesAreWrittenAndUnwritablePathsThrow) {
  const TetMesh mesh = MakeBoxTetMesh({2, 2, 2}, {1, 1, 1});
  const std::string path = std::string(NSIM_BINARY_DIR) + "/vtk_writer_test.vtk";
  WriteVtkTetMesh(path, mesh, mesh.X);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  std::ostringstream expected;
  WriteVtkTetMesh(expected, mesh, mesh.X);
  EXPECT_EQ(text.str(), expected.str());
  const std::string bad = std::string(NSIM_BINARY_DIR) + "/no/such/dir/x.vtk";
  try {
    WriteVtkSurface(bad, mesh, mesh.X);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
  }
}

}  // namespace
}  // namespace nsim
