#include "common/mesh/gmsh_reader.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "common/core/error.h"

namespace nsim {
namespace {

// Two tetrahedra sharing the face (20, 30, 40); the second is listed inverted. Node 99 is used
// by no tetrahedron; a point, a line and a triangle (listed inward) accompany them.
const char kMsh22[] = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
1
3 1 "liver"
$EndPhysicalNames
$Nodes
6
10 0 0 0
20 1 0 0
30 0 1 0
40 0 0 1
55 1 1 1
99 5 5 5
$EndNodes
$Elements
5
1 15 2 0 1 10
2 1 2 0 1 10 20
3 2 2 0 7 10 20 30
4 4 2 1 3 10 20 30 40
5 4 2 1 3 20 40 30 55
$EndElements
)";

// The same mesh in format 4.1, with an $Entities section and a parametric node block.
const char kMsh41[] = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Entities
1 1 1 1
1 0 0 0 0
1 0 0 0 1 0 0 0
7 0 0 0 1 1 0 0 0
3 0 0 0 1 1 1 1 1 0
$EndEntities
$Nodes
3 6 10 99
0 1 0 1
10
0 0 0
2 7 1 2
20
30
1 0 0 0.5 0.5
0 1 0 0.5 0.5
3 3 0 3
40
55
99
0 0 1
1 1 1
5 5 5
$EndNodes
$Elements
4 5 1 5
0 1 15 1
1 10
1 1 1 1
2 10 20
2 7 2 1
3 10 20 30
3 3 4 2
4 10 20 30 40
5 20 40 30 55
$EndElements
)";

TetMesh Parse(const std::string& text, GmshFileInfo* info = nullptr,
              const GmshReadOptions& options = {}) {
  std::istringstream in(text);
  return ParseGmshMesh(in, "inline.msh", options, info);
}

// replaces the single occurrence of `from` (the test fails if it is absent or repeated)
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  EXPECT_EQ(text.find(from, pos + 1), std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

// expects an InputError whose message starts with "inline.msh:<line>:" and contains `what`
void ExpectError(const std::string& text, long line, const std::string& what,
                 const GmshReadOptions& options = {}) {
  try {
    Parse(text, nullptr, options);
    ADD_FAILURE() << "no InputError; expected line " << line << ": " << what;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(Str("inline.msh:", line, ": "), 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

void ExpectSameMesh(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  EXPECT_EQ(a.X, b.X);
  ASSERT_EQ(a.num_tets(), b.num_tets());
  for (int e = 0; e < a.num_tets(); ++e) EXPECT_EQ(a.tets[e], b.tets[e]);
  ASSERT_EQ(a.surface.size(), b.surface.size());
  for (size_t f = 0; f < a.surface.size(); ++f) EXPECT_EQ(a.surface[f], b.surface[f]);
}

TEST(GmshReader, ReadsFormat22) {
  GmshFileInfo info;
  const TetMesh mesh = Parse(kMsh22, &info);
  EXPECT_EQ(info.version, "2.2");
  ASSERT_EQ(mesh.num_nodes(), 5);
  EXPECT_EQ(info.node_tags, (std::vector<long long>{10, 20, 30, 40, 55}));
  EXPECT_EQ(info.num_dropped_nodes, 1);
  EXPECT_EQ(mesh.X.col(4), Eigen::Vector3d(1, 1, 1));
  ASSERT_EQ(mesh.num_tets(), 2);
  EXPECT_EQ(mesh.tets[0], Eigen::Vector4i(0, 1, 2, 3));
  // the inverted second tet (20 40 30 55) is reoriented by swapping its last two nodes
  EXPECT_EQ(mesh.tets[1], Eigen::Vector4i(1, 3, 4, 2));
  EXPECT_EQ(info.num_reoriented_tets, 1);
  for (const auto& t : mesh.tets)
    EXPECT_GT(
        SignedTetVolume(mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]), mesh.X.col(t[3])), 0);
  EXPECT_EQ(info.tet_entities, (std::vector<int>{3, 3}));
  EXPECT_EQ(info.tet_lines, (std::vector<long>{22, 23}));
  EXPECT_EQ(info.num_ignored_elements, 2);  // point and line
  // 2 tets sharing one face: 6 boundary faces
  EXPECT_EQ(mesh.surface.size(), 6u);
  // the file's inward triangle (10 20 30) comes back outward: normal -z
  ASSERT_EQ(info.triangles.size(), 1u);
  EXPECT_EQ(info.num_boundary_triangles, 1);
  EXPECT_EQ(info.triangle_entities, (std::vector<int>{7}));
  const Eigen::Vector3i& t = info.triangles[0];
  const Eigen::Vector3d n =
      (mesh.X.col(t[1]) - mesh.X.col(t[0])).cross(mesh.X.col(t[2]) - mesh.X.col(t[0]));
  EXPECT_LT(n.z(), 0);
}

TEST(GmshReader, Format41GivesTheSameMeshAsFormat22) {
  GmshFileInfo info22, info41;
  const TetMesh mesh22 = Parse(kMsh22, &info22);
  const TetMesh mesh41 = Parse(kMsh41, &info41);
  EXPECT_EQ(info41.version, "4.1");
  ExpectSameMesh(mesh22, mesh41);
  EXPECT_EQ(info41.node_tags, info22.node_tags);
  EXPECT_EQ(info41.tet_entities, info22.tet_entities);
  EXPECT_EQ(info41.num_reoriented_tets, 1);
  EXPECT_EQ(info41.num_ignored_elements, 2);
  EXPECT_EQ(info41.triangles, info22.triangles);
  EXPECT_EQ(info41.tet_lines, (std::vector<long>{38, 39}));
}

TEST(GmshReader, ToleratesCrlfBlankLinesAndOtherSections) {
  std::string text =
      Replace(kMsh22, "$Nodes\n", "$Comments\nmade by hand\n$EndComments\n\n$Nodes\n");
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  crlf += "$NodeData\n1\n\"u\"\n$EndNodeData\n";
  ExpectSameMesh(Parse(kMsh22), Parse(crlf));
}

TEST(GmshReader, VersionAndEncodingErrors) {
  ExpectError(Replace(kMsh22, "2.2 0 8", "3.0 0 8"), 2, "unsupported MSH format version '3.0'");
  ExpectError(Replace(kMsh22, "2.2 0 8", "4 0 8"), 2, "expected 2.2 or 4.1");
  ExpectError(Replace(kMsh41, "4.1 0 8", "4.1 1 8"), 2, "binary MSH files are not supported");
  ExpectError(Replace(kMsh22, "2.2 0 8", "2.2 0"), 2, "expected the format line");
  ExpectError(Replace(kMsh22, "$EndMeshFormat", "$EndFormat"), 3, "expected $EndMeshFormat");
  ExpectError("", 1, "no $MeshFormat section");
  ExpectError("hello\n", 1, "expected a section header");
  ExpectError(Replace(kMsh22, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n", ""), 1,
              "expected $MeshFormat as the first section");
}

TEST(GmshReader, MissingSections) {
  const std::string no_nodes = Replace(
      kMsh22, "$Nodes\n6\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n55 1 1 1\n99 5 5 5\n$EndNodes\n",
      "");
  ExpectError(no_nodes, 15, "no $Nodes section");
  const std::string no_elements =
      std::string(kMsh22).substr(0, std::string(kMsh22).find("$Elements"));
  ExpectError(no_elements, 16, "no $Elements section");
  ExpectError(Replace(kMsh22, "$EndPhysicalNames\n", ""), 23,
              "section $PhysicalNames opened at line 4");
  ExpectError(Replace(kMsh22, "$EndElements\n", ""), 23, "expected $EndElements");
  ExpectError(Replace(kMsh22, "$EndNodes", "$EndNodes\n$EndNodes"), 17, "closes no open section");
  ExpectError(Replace(kMsh22, "$Elements", "$Nodes\n0\n$EndNodes\n$Elements"), 17,
              "duplicate $Nodes");
}

TEST(GmshReader, NodeErrors) {
  ExpectError(Replace(kMsh22, "30 0 1 0", "30 0 abc 0"), 12,
              "expected node y (a finite number), got 'abc'");
  ExpectError(Replace(kMsh22, "30 0 1 0", "30 0 nan 0"), 12, "finite number");
  ExpectError(Replace(kMsh22, "30 0 1 0", "30 0 1"), 12, "expected a node line 'tag x y z'");
  ExpectError(Replace(kMsh22, "30 0 1 0", "20 0 1 0"), 12,
              "duplicate node tag 20 (first defined at line 11)");
  ExpectError(Replace(kMsh22, "30 0 1 0", "-3 0 1 0"), 12, "node tag > 0");
  ExpectError(Replace(kMsh22, "$Nodes\n6", "$Nodes\n7"), 16, "expected 7 nodes, got 6");
  ExpectError(Replace(kMsh22, "$Nodes\n6", "$Nodes\nsix"), 9, "the number of nodes (an integer)");
  ExpectError(Replace(kMsh41, "3 6 10 99", "3 7 10 99"), 27, "announces 7 nodes");
  ExpectError(Replace(kMsh41, "2 7 1 2\n", "2 7 2 2\n"), 16, "expected a parametric flag 0 or 1");
  ExpectError(Replace(kMsh41, "1 0 0 0.5 0.5", "1 0 0"), 19, "parameters");
  ExpectError(Replace(kMsh41, "3 3 0 3\n", "3 3 0 4\n"), 21, "more nodes than the header's 6");
}

TEST(GmshReader, HeaderCountsAreCheckedAgainstTheFileSizeBeforeAllocating) {
  // a header announcing 1e12 nodes was a bad_alloc (exit 1): now an error at its line
  ExpectError(Replace(kMsh22, "$Nodes\n6", "$Nodes\n1000000000000"), 9,
              "the header announces 1000000000000 nodes, more than");
  ExpectError(Replace(kMsh22, "$Nodes\n6", "$Nodes\n100000"), 9,
              "more than the rest of the file");
  ExpectError(Replace(kMsh41, "3 6 10 99", "3 60000000 10 99"), 12,
              "announces 60000000 nodes, more than the rest of the file");
  ExpectError(Replace(kMsh41, "3 6 10 99", "3000000000000 6 10 99"), 12, "node blocks");
}

TEST(GmshReader, DevicesAreNotMeshFiles) {
  try {
    ReadGmshMesh("/dev/zero");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/dev/zero: expected a regular file", 0), 0u)
        << e.what();
  }
}

TEST(GmshReader, ElementErrors) {
  ExpectError(Replace(kMsh22, "4 4 2 1 3 10 20 30 40", "4 4 2 1 3 10 20 30 41"), 22,
              "unknown node tag 41");
  ExpectError(Replace(kMsh22, "4 4 2 1 3 10 20 30 40", "4 4 2 1 3 10 20 30"), 22,
              "4-node tetrahedron line with 2 tags");
  ExpectError(Replace(kMsh22, "4 4 2 1 3 10 20 30 40", "4 4 2 1 3 10 20 30 20"), 22,
              "repeats node tag 20");
  ExpectError(Replace(kMsh22, "4 4 2 1 3 10 20 30 40", "4 x 2 1 3 10 20 30 40"), 22,
              "element type");
  ExpectError(Replace(kMsh22, "$Elements\n5", "$Elements\n6"), 24, "expected 6 elements, got 5");
  // node 55 moved into the plane of 20, 30, 40: the second tet is flat
  ExpectError(Replace(kMsh22, "55 1 1 1", "55 0.5 0.5 0"), 23, "degenerate tetrahedron");
  // coplanar with 20 30 40 (x + y + z = 1)
  ExpectError(Replace(kMsh22, "55 1 1 1", "55 0.2 0.3 0.5"), 23, "degenerate tetrahedron");
  GmshReadOptions strict;
  strict.reorient_inverted = false;
  ExpectError(kMsh22, 23, "inverted tetrahedron", strict);
  ExpectError(Replace(kMsh41, "3 10 20 30\n3 3 4 2", "3 10 20 30 77\n3 3 4 2"), 36,
              "3-node triangle line");
  ExpectError(Replace(kMsh41, "4 5 1 5", "4 6 1 5"), 39, "announces 6 elements");
  ExpectError(Replace(Replace(kMsh41, "4 5 1 5", "4 6 1 5"), "3 3 4 2", "3 3 4 3"), 40,
              "expected 3 elements in the block, got 2");
}

TEST(GmshReader, RejectsMeshesWithoutLinearTets) {
  const std::string only_surface =
      Replace(Replace(kMsh22, "4 4 2 1 3 10 20 30 40\n", ""), "5 4 2 1 3 20 40 30 55\n", "");
  ExpectError(Replace(only_surface, "$Elements\n5", "$Elements\n3"), 17,
              "expected linear tetrahedra (element type 4), found none (only 1 x 2-node line, "
              "1 x 1-node point)");
  const std::string quadratic =
      Replace(Replace(only_surface, "$Elements\n5", "$Elements\n4"), "$EndElements",
              "4 11 2 1 3 10 20 30 40 10 20 30 40 55 99\n$EndElements");
  ExpectError(quadratic, 17, "10-node tetrahedron");
}

TEST(GmshReader, RejectsNonConformingMeshes) {
  // a third tet on the face (20, 30, 40), overlapping the first
  const std::string text = Replace(Replace(kMsh22, "$Elements\n5", "$Elements\n6"), "$EndElements",
                                   "6 4 2 1 3 20 30 40 99\n$EndElements");
  ExpectError(text, 24, "non-conforming mesh");
}

TEST(GmshReader, FileErrorsNameThePath) {
  const std::string path = std::string(NSIM_BINARY_DIR) + "/gmsh_reader_test_bad.msh";
  {
    std::ofstream out(path);
    out << Replace(kMsh22, "30 0 1 0", "30 0 1 zero");
  }
  try {
    ReadGmshMesh(path);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ":12: expected node z", 0), 0u) << e.what();
  }
  std::remove(path.c_str());
  try {
    ReadGmshMesh(path);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": cannot open"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace nsim
