#pragma once
// Topological neighbourhoods of a tetrahedral mesh: node -> tets, tet neighbours across faces,
// the surface node set and the unique edges.

#include <Eigen/Core>
#include <vector>

#include "common/mesh/tet_mesh.h"

namespace nsim {

/// Local node indices of the face of a tetrahedron opposite local vertex k, ordered so that the
/// face normal (right-hand rule) points out of a positively oriented tetrahedron.
inline constexpr int kTetFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// Adjacency of a TetMesh. Node -> tet incidence is stored compressed (CSR).
struct MeshAdjacency {
  /// tets around node i are node_tets[node_tet_offsets[i] .. node_tet_offsets[i + 1]),
  /// ascending; node_tet_offsets has #nodes + 1 entries
  std::vector<int> node_tet_offsets;
  std::vector<int> node_tets;
  /// tet_neighbors[e][k]: the tet sharing the face of e opposite its local vertex k
  /// (kTetFaces[k]), or -1 when that face is on the boundary; #tets
  std::vector<Eigen::Vector4i> tet_neighbors;
  /// per TetMesh::surface triangle: the tet it is a face of; #surface triangles
  std::vector<int> surface_tets;
  /// nodes on the boundary surface, ascending
  std::vector<int> surface_nodes;
  /// unique edges (i < j), sorted lexicographically
  std::vector<Eigen::Vector2i> edges;

  /// Number of tets around node i.
  int NodeDegree(int i) const { return node_tet_offsets[i + 1] - node_tet_offsets[i]; }
};

/// Per TetMesh::surface triangle, the tet it is a face of (-1: none), by matching sorted node
/// triples: MeshAdjacency::surface_tets alone, without the rest of CalcMeshAdjacency's work
/// (2.6 against 11.8 ms on the 2660-node liver, mesh_bench BuildSurfaceLocator/2660).
std::vector<int> CalcSurfaceTets(const TetMesh& mesh);

/// Computes all adjacency of `mesh` in O(#tets log #tets). Aborts (internal invariant) when a
/// face is shared by more than two tetrahedra or a surface triangle is no tet face.
MeshAdjacency CalcMeshAdjacency(const TetMesh& mesh);

}  // namespace nsim
