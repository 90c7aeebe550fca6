#include "common/mesh/tet_mesh.h"

#include <gtest/gtest.h>

namespace nsim {
namespace {

TEST(TetMesh, BoxVolumesArePositiveAndSumToTheBox) {
  const Eigen::Vector3d size(0.3, 0.2, 0.1);
  const TetMesh mesh = MakeBoxTetMesh({4, 3, 5}, size, {1, 2, 3});
  EXPECT_EQ(mesh.num_nodes(), 60);
  EXPECT_EQ(mesh.num_tets(), 6 * 3 * 2 * 4);
  double total = 0;
  for (const auto& t : mesh.tets) {
    const double v =
        SignedTetVolume(mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]), mesh.X.col(t[3]));
    EXPECT_GT(v, 0);
    total += v;
  }
  EXPECT_NEAR(total, size.prod(), 1e-12 * size.prod());
}

TEST(TetMesh, SurfaceIsClosedAndOutward) {
  const Eigen::Vector3d size(0.3, 0.2, 0.1);
  const TetMesh mesh = MakeBoxTetMesh({4, 3, 5}, size);
  // 2 triangles per boundary quad
  EXPECT_EQ(mesh.surface.size(), 2u * (2 * (3 * 2) + 2 * (3 * 4) + 2 * (2 * 4)));
  // divergence theorem: sum of (centroid . n) area / 3 equals the volume when normals point out
  double volume = 0;
  for (const auto& f : mesh.surface) {
    const Eigen::Vector3d a = mesh.X.col(f[0]), b = mesh.X.col(f[1]), c = mesh.X.col(f[2]);
    volume += a.dot((b - a).cross(c - a)) / 6.0;
  }
  EXPECT_NEAR(volume, size.prod(), 1e-12);
}

}  // namespace
}  // namespace nsim
