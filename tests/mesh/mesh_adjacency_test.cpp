#include "common/mesh/mesh_adjacency.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace nsim {
namespace {

TEST(MeshAdjacency, BoxMesh) {
  const int nx = 4, ny = 3, nz = 5;
  const TetMesh mesh = MakeBoxTetMesh({nx, ny, nz}, {0.3, 0.2, 0.4});
  const MeshAdjacency adj = CalcMeshAdjacency(mesh);

  // node -> tets: each tet listed under each of its nodes, lists ascending
  ASSERT_EQ(adj.node_tet_offsets.size(), static_cast<size_t>(mesh.num_nodes() + 1));
  EXPECT_EQ(adj.node_tets.size(), 4u * mesh.num_tets());
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const auto begin = adj.node_tets.begin() + adj.node_tet_offsets[i];
    const auto end = adj.node_tets.begin() + adj.node_tet_offsets[i + 1];
    EXPECT_TRUE(std::is_sorted(begin, end));
    EXPECT_GT(adj.NodeDegree(i), 0);
    for (auto it = begin; it != end; ++it) EXPECT_TRUE((mesh.tets[*it].array() == i).any());
  }

  // neighbours: symmetric, sharing exactly the face opposite the local vertex
  int boundary_faces = 0;
  for (int e = 0; e < mesh.num_tets(); ++e)
    for (int k = 0; k < 4; ++k) {
      const int n = adj.tet_neighbors[e][k];
      if (n < 0) {
        ++boundary_faces;
        continue;
      }
      EXPECT_TRUE((adj.tet_neighbors[n].array() == e).any());
      for (int f = 0; f < 3; ++f)
        EXPECT_TRUE((mesh.tets[n].array() == mesh.tets[e][kTetFaces[k][f]]).any());
      EXPECT_FALSE((mesh.tets[n].array() == mesh.tets[e][k]).any());
    }
  EXPECT_EQ(boundary_faces, static_cast<int>(mesh.surface.size()));

  // surface triangles belong to their tet
  ASSERT_EQ(adj.surface_tets.size(), mesh.surface.size());
  for (size_t f = 0; f < mesh.surface.size(); ++f)
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE((mesh.tets[adj.surface_tets[f]].array() == mesh.surface[f][k]).any());

  // surface nodes: all but the interior grid nodes
  EXPECT_EQ(adj.surface_nodes.size(),
            static_cast<size_t>(nx * ny * nz - (nx - 2) * (ny - 2) * (nz - 2)));
  EXPECT_TRUE(std::is_sorted(adj.surface_nodes.begin(), adj.surface_nodes.end()));

  // edges, by Euler's formula for a ball: V - E + F - T = 1 with F = (4 T + boundary) / 2
  const int faces = (4 * mesh.num_tets() + static_cast<int>(mesh.surface.size())) / 2;
  EXPECT_EQ(static_cast<int>(adj.edges.size()), mesh.num_nodes() + faces - mesh.num_tets() - 1);
  for (size_t i = 0; i < adj.edges.size(); ++i) {
    EXPECT_LT(adj.edges[i][0], adj.edges[i][1]);
    if (i > 0) {
      EXPECT_TRUE(std::lexicographical_compare(adj.edges[i - 1].data(), adj.edges[i - 1].data() + 2,
                                               adj.edges[i].data(), adj.edges[i].data() + 2));
    }
  }
}

TEST(MeshAdjacency, SingleTet) {
  TetMesh mesh;
  mesh.X.resize(3, 4);
  mesh.X << 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
  mesh.tets = {Eigen::Vector4i(0, 1, 2, 3)};
  mesh.surface = ComputeBoundarySurface(mesh.tets);
  const MeshAdjacency adj = CalcMeshAdjacency(mesh);
  EXPECT_EQ(adj.tet_neighbors[0], Eigen::Vector4i::Constant(-1));
  EXPECT_EQ(adj.edges.size(), 6u);
  EXPECT_EQ(adj.surface_nodes, (std::vector<int>{0, 1, 2, 3}));
}

// CalcSurfaceTets (a face map of the surface) against CalcMeshAdjacency's surface_tets (from
// the sorted faces of all tets), and -1 for a triangle that is no tet's face
TEST(MeshAdjacency, SurfaceTetsAloneAgreeWithTheFullAdjacency) {
  TetMesh mesh = MakeBoxTetMesh({4, 3, 5}, {0.3, 0.2, 0.4});
  const std::vector<int> owners = CalcSurfaceTets(mesh);
  EXPECT_EQ(owners, CalcMeshAdjacency(mesh).surface_tets);
  EXPECT_EQ(owners.size(), mesh.surface.size());
  mesh.surface.push_back(Eigen::Vector3i(0, mesh.num_nodes() - 1, 1));  // spans the box
  EXPECT_EQ(CalcSurfaceTets(mesh).back(), -1);
}

}  // namespace
}  // namespace nsim
