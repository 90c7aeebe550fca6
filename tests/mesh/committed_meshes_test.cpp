// Checks the meshes committed in configs/meshes/ (made by scripts/make_meshes.sh): sizes,
// anatomical dimensions and frame, element validity, closed outward surfaces, quality.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <utility>

#include "common/mesh/gmsh_reader.h"
#include "common/mesh/mesh_quality.h"

namespace nsim {
namespace {

std::string MeshPath(const std::string& name) {
  return std::string(NSIM_SOURCE_DIR) + "/configs/meshes/" + name;
}

// every surface edge is shared by exactly two triangles, traversed in opposite directions
void ExpectClosedOrientedSurface(const TetMesh& mesh) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : mesh.surface)
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second << " repeated";
    const auto twin = directed.find({edge.second, edge.first});
    EXPECT_TRUE(twin != directed.end() && twin->second == 1)
        << "edge " << edge.first << "-" << edge.second << " has no opposite twin";
  }
}

struct LiverCase {
  const char* file;
  int min_nodes, max_nodes;
};

class LiverMeshTest : public ::testing::TestWithParam<LiverCase> {};

TEST_P(LiverMeshTest, HasAdultLiverDimensionsAndValidElements) {
  const LiverCase& c = GetParam();
  GmshFileInfo info;
  const TetMesh mesh = ReadGmshMesh(MeshPath(c.file), GmshReadOptions(), &info);
  EXPECT_GE(mesh.num_nodes(), c.min_nodes);
  EXPECT_LE(mesh.num_nodes(), c.max_nodes);
  EXPECT_EQ(info.version, "4.1");
  EXPECT_EQ(info.num_reoriented_tets, 0);  // gmsh writes positive tets
  EXPECT_EQ(info.num_dropped_nodes, 0);

  const MeshQualityReport q = CalcMeshQuality(mesh);
  // adult liver (REFERENCE.md): transverse 20-22.5 cm (x), antero-posterior 10-12.5 cm (y),
  // craniocaudal 15-17.5 cm (z); the mesh is 21 x 11 x 16 cm, nodes on the curved surface may
  // fall short of the geometric extent by a fraction of an element
  const Eigen::Vector3d size = q.bbox_max - q.bbox_min;
  const double kShortfall = 2e-3;  // m
  EXPECT_NEAR(size.x(), 0.210, kShortfall);
  EXPECT_NEAR(size.y(), 0.110, kShortfall);
  EXPECT_NEAR(size.z(), 0.160, kShortfall);
  // bounding-box centre at the origin
  EXPECT_LT((0.5 * (q.bbox_max + q.bbox_min)).norm(), kShortfall);
  // the right lobe (+x) is the bulk of the organ: more volume right of the centre
  double right = 0, left = 0;
  for (const auto& t : mesh.tets) {
    const Eigen::Vector3d centroid =
        0.25 * (mesh.X.col(t[0]) + mesh.X.col(t[1]) + mesh.X.col(t[2]) + mesh.X.col(t[3]));
    const double v =
        SignedTetVolume(mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]), mesh.X.col(t[3]));
    (centroid.x() > 0 ? right : left) += v;
  }
  EXPECT_GT(right, 1.5 * left);

  EXPECT_EQ(q.num_inverted, 0);
  EXPECT_GT(q.min_volume, 0);
  // adult liver volume 1.2-1.9 L
  EXPECT_GT(q.total_volume, 1.2e-3);
  EXPECT_LT(q.total_volume, 1.9e-3);
  // closed, outward surface: the divergence theorem gives back the tets' volume
  EXPECT_NEAR(q.surface_volume, q.total_volume, 1e-10 * q.total_volume);
  ExpectClosedOrientedSurface(mesh);
  // every file triangle (gmsh's surface mesh) is on the computed boundary, and vice versa
  EXPECT_EQ(info.num_boundary_triangles, static_cast<int>(info.triangles.size()));
  EXPECT_EQ(info.triangles.size(), mesh.surface.size());
  // quality of an optimized Delaunay mesh: no slivers
  EXPECT_GT(q.min_radius_ratio, 0.1) << FormatMeshQuality(q);
  EXPECT_GT(q.mean_radius_ratio, 0.75) << FormatMeshQuality(q);
  EXPECT_GT(q.min_dihedral, 10.0 * 3.14159265358979 / 180) << FormatMeshQuality(q);
}

INSTANTIATE_TEST_SUITE_P(Liver, LiverMeshTest,
                         ::testing::Values(LiverCase{"liver_700.msh", 600, 800},
                                           LiverCase{"liver_2660.msh", 2500, 2800},
                                           LiverCase{"liver_10000.msh", 9000, 11000},
                                           LiverCase{"liver_model_2000.msh", 1900, 2300}),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           return name.substr(0, name.find('.'));
                         });

// the controller's model is meshed separately from the patient's liver (no "inverse crime"):
// the same organ, but (almost) none of its nodes where a patient node is
TEST(LiverModelMesh, SharesNoNodesWithThePatientMesh) {
  const TetMesh patient = ReadGmshMesh(MeshPath("liver_2660.msh"));
  const TetMesh model = ReadGmshMesh(MeshPath("liver_model_2000.msh"));
  int shared = 0;
  for (int i = 0; i < model.num_nodes(); ++i) {
    double nearest = INFINITY;
    for (int j = 0; j < patient.num_nodes(); ++j)
      nearest = std::min(nearest, (model.X.col(i) - patient.X.col(j)).squaredNorm());
    if (nearest < 1e-12) ++shared;  // within 1 um
  }
  EXPECT_LT(shared, model.num_nodes() / 50) << shared << " of " << model.num_nodes();
  EXPECT_GE(model.num_nodes(), 2000);
}

TEST(SkinPatch, IsAThinSlabOf144Nodes) {
  GmshFileInfo info;
  const TetMesh mesh = ReadGmshMesh(MeshPath("skin_patch.msh"), GmshReadOptions(), &info);
  EXPECT_EQ(info.version, "2.2");
  EXPECT_EQ(mesh.num_nodes(), 144);
  const MeshQualityReport q = CalcMeshQuality(mesh);
  const double kTol = 1e-12;
  EXPECT_TRUE(q.bbox_min.isApprox(Eigen::Vector3d(-0.05, -0.002, -0.05), kTol)) << q.bbox_min;
  EXPECT_TRUE(q.bbox_max.isApprox(Eigen::Vector3d(0.05, 0.002, 0.05), kTol)) << q.bbox_max;
  EXPECT_EQ(q.num_inverted, 0);
  EXPECT_NEAR(q.total_volume, 0.1 * 0.1 * 0.004, 1e-12);
  EXPECT_NEAR(q.surface_volume, q.total_volume, 1e-12);
  ExpectClosedOrientedSurface(mesh);
  // one layer of elements: every node is on the surface
  std::vector<char> on_surface(mesh.num_nodes(), 0);
  for (const auto& f : mesh.surface) on_surface[f[0]] = on_surface[f[1]] = on_surface[f[2]] = 1;
  for (int i = 0; i < mesh.num_nodes(); ++i) EXPECT_TRUE(on_surface[i]) << i;
}

}  // namespace
}  // namespace nsim
