#include "common/mesh/mesh_adjacency.h"

#include <algorithm>
#include <array>
#include <map>

#include "common/core/error.h"

namespace nsim {

std::vector<int> CalcSurfaceTets(const TetMesh& mesh) {
  std::map<std::array<int, 3>, int> index;
  for (int i = 0; i < static_cast<int>(mesh.surface.size()); ++i) {
    std::array<int, 3> key{mesh.surface[i][0], mesh.surface[i][1], mesh.surface[i][2]};
    std::sort(key.begin(), key.end());
    index.emplace(key, i);
  }
  std::vector<int> owners(mesh.surface.size(), -1);
  for (int e = 0; e < mesh.num_tets(); ++e)
    for (const auto& f : kTetFaces) {
      std::array<int, 3> key{mesh.tets[e][f[0]], mesh.tets[e][f[1]], mesh.tets[e][f[2]]};
      std::sort(key.begin(), key.end());
      const auto it = index.find(key);
      if (it != index.end()) owners[it->second] = e;
    }
  return owners;
}

MeshAdjacency CalcMeshAdjacency(const TetMesh& mesh) {
  const int n = mesh.num_nodes();
  const int m = mesh.num_tets();
  MeshAdjacency adj;

  // node -> tets (counting sort keeps each list ascending)
  adj.node_tet_offsets.assign(n + 1, 0);
  for (const auto& t : mesh.tets)
    for (int k = 0; k < 4; ++k) {
      NSIM_CHECK(t[k] >= 0 && t[k] < n, "tet node index ", t[k], " out of range");
      ++adj.node_tet_offsets[t[k] + 1];
    }
  for (int i = 0; i < n; ++i) adj.node_tet_offsets[i + 1] += adj.node_tet_offsets[i];
  adj.node_tets.resize(adj.node_tet_offsets[n]);
  std::vector<int> fill(adj.node_tet_offsets.begin(), adj.node_tet_offsets.end() - 1);
  for (int e = 0; e < m; ++e)
    for (int k = 0; k < 4; ++k) adj.node_tets[fill[mesh.tets[e][k]]++] = e;

  // neighbours across faces: sort (face key, tet, local face) records, pair equal keys
  struct FaceRecord {
    std::array<int, 3> key;
    int tet;
    int local;
  };
  std::vector<FaceRecord> faces;
  faces.reserve(4 * static_cast<size_t>(m));
  for (int e = 0; e < m; ++e)
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> key{mesh.tets[e][kTetFaces[k][0]], mesh.tets[e][kTetFaces[k][1]],
                             mesh.tets[e][kTetFaces[k][2]]};
      std::sort(key.begin(), key.end());
      faces.push_back({key, e, k});
    }
  std::sort(faces.begin(), faces.end(), [](const FaceRecord& a, const FaceRecord& b) {
    return a.key != b.key ? a.key < b.key : a.tet < b.tet;
  });
  adj.tet_neighbors.assign(m, Eigen::Vector4i::Constant(-1));
  std::map<std::array<int, 3>, int> boundary_owner;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    NSIM_CHECK(j - i <= 2, "a face is shared by ", j - i, " tetrahedra");
    if (j - i == 2) {
      adj.tet_neighbors[faces[i].tet][faces[i].local] = faces[i + 1].tet;
      adj.tet_neighbors[faces[i + 1].tet][faces[i + 1].local] = faces[i].tet;
    } else {
      boundary_owner.emplace(faces[i].key, faces[i].tet);
    }
    i = j;
  }

  // surface triangles -> tets, surface nodes
  std::vector<char> on_surface(n, 0);
  adj.surface_tets.reserve(mesh.surface.size());
  for (const auto& f : mesh.surface) {
    std::array<int, 3> key{f[0], f[1], f[2]};
    std::sort(key.begin(), key.end());
    const auto it = boundary_owner.find(key);
    NSIM_CHECK(it != boundary_owner.end(), "surface triangle (", f.transpose(),
               ") is no boundary face of the tetrahedra");
    adj.surface_tets.push_back(it->second);
    for (int k = 0; k < 3; ++k) on_surface[f[k]] = 1;
  }
  for (int i = 0; i < n; ++i)
    if (on_surface[i]) adj.surface_nodes.push_back(i);

  // unique edges
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  std::vector<std::pair<int, int>> edges;
  edges.reserve(6 * static_cast<size_t>(m));
  for (const auto& t : mesh.tets)
    for (const auto& e : kEdges)
      edges.emplace_back(std::min(t[e[0]], t[e[1]]), std::max(t[e[0]], t[e[1]]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  adj.edges.reserve(edges.size());
  for (const auto& [a, b] : edges) adj.edges.emplace_back(a, b);
  return adj;
}

}  // namespace nsim
