#include "common/mesh/tet_mesh.h"

#include <algorithm>
#include <array>
#include <map>

#include "common/core/error.h"

namespace nsim {

double SignedTetVolume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

void OrientTetsPositively(TetMesh& mesh) {
  for (auto& t : mesh.tets) {
    if (SignedTetVolume(mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]), mesh.X.col(t[3])) < 0)
      std::swap(t[2], t[3]);
  }
}

std::vector<Eigen::Vector3i> ComputeBoundarySurface(const std::vector<Eigen::Vector4i>& tets) {
  // faces opposite each local vertex; a face shared by two tets is interior
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<int, 3>, std::pair<int, Eigen::Vector3i>>
      faces;  // sorted key -> (count, face)
  for (const auto& t : tets) {
    for (const auto& f : kFace) {
      Eigen::Vector3i face(t[f[0]], t[f[1]], t[f[2]]);
      std::array<int, 3> key{face[0], face[1], face[2]};
      std::sort(key.begin(), key.end());
      auto [it, inserted] = faces.try_emplace(key, 0, face);
      it->second.first++;
    }
  }
  std::vector<Eigen::Vector3i> surface;
  for (const auto& [key, entry] : faces) {
    if (entry.first == 1) surface.push_back(entry.second);
  }
  return surface;
}

TetMesh MakeBoxTetMesh(const Eigen::Vector3i& nodes, const Eigen::Vector3d& size,
                       const Eigen::Vector3d& origin) {
  NSIM_CHECK((nodes.array() >= 2).all(), "need at least 2 nodes per axis, got ", nodes.transpose());
  NSIM_CHECK((size.array() > 0).all(), "box size must be positive, got ", size.transpose());
  TetMesh mesh;
  const int nx = nodes[0], ny = nodes[1], nz = nodes[2];
  mesh.X.resize(3, nx * ny * nz);
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        mesh.X.col(id(i, j, k)) =
            origin +
            Eigen::Vector3d(size[0] * i / (nx - 1), size[1] * j / (ny - 1), size[2] * k / (nz - 1));
  // Kuhn subdivision: 6 tets around the diagonal from corner 0 to corner 7 of each cube
  static constexpr int kPaths[6][3] = {{1, 3, 7}, {1, 5, 7}, {2, 3, 7},
                                       {2, 6, 7}, {4, 5, 7}, {4, 6, 7}};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        int c[8];
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        for (const auto& p : kPaths) mesh.tets.emplace_back(c[0], c[p[0]], c[p[1]], c[p[2]]);
      }
  OrientTetsPositively(mesh);
  mesh.surface = ComputeBoundarySurface(mesh.tets);
  return mesh;
}

}  // namespace nsim
