#include "common/mesh/mesh_quality.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nsim {
namespace {

constexpr double kPi = 3.14159265358979323846;
const double kEps = 1e-12;

// regular tetrahedron with edge length l
void Regular(double l, Eigen::Vector3d p[4]) {
  p[0] = l * Eigen::Vector3d(1, 1, 1) / std::sqrt(8.0);
  p[1] = l * Eigen::Vector3d(1, -1, -1) / std::sqrt(8.0);
  p[2] = l * Eigen::Vector3d(-1, 1, -1) / std::sqrt(8.0);
  p[3] = l * Eigen::Vector3d(-1, -1, 1) / std::sqrt(8.0);
}

TEST(MeshQuality, RegularTetrahedronIsPerfectAtEveryScale) {
  for (double l : {1e-3, 1.0, 1e3}) {
    Eigen::Vector3d p[4];
    Regular(l, p);
    const TetQuality q = CalcTetQuality(p[0], p[1], p[2], p[3]);
    const double volume = std::abs(l * l * l / (6 * std::sqrt(2.0)));
    EXPECT_NEAR(std::abs(q.volume), volume, kEps * volume);
    EXPECT_NEAR(std::abs(q.radius_ratio), 1.0, kEps);
    EXPECT_NEAR(q.edge_ratio, 1.0, kEps);
    EXPECT_NEAR(q.min_dihedral, std::acos(1.0 / 3.0), 1e-9);
    EXPECT_NEAR(q.max_dihedral, std::acos(1.0 / 3.0), 1e-9);
    EXPECT_NEAR(q.min_edge, l, kEps * l);
  }
}

TEST(MeshQuality, CornerTetrahedron) {
  // (0,0,0), (1,0,0), (0,1,0), (0,0,1): V = 1/6, faces 3 x 1/2 + sqrt(3)/2,
  // r_in = 3V / A, circumradius sqrt(3)/2
  const TetQuality q = CalcTetQuality({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  EXPECT_NEAR(q.volume, 1.0 / 6, kEps);
  const double r_in = 0.5 / (1.5 + std::sqrt(3.0) / 2);
  EXPECT_NEAR(q.radius_ratio, 3 * r_in / (std::sqrt(3.0) / 2), kEps);
  EXPECT_NEAR(q.edge_ratio, std::sqrt(2.0), kEps);
  // coordinate faces meet at right angles; each meets the slanted face at acos(1/sqrt(3))
  EXPECT_NEAR(q.min_dihedral, std::acos(1 / std::sqrt(3.0)), 1e-9);
  EXPECT_NEAR(q.max_dihedral, kPi / 2, 1e-9);
  // swapping two nodes inverts it
  const TetQuality inverted = CalcTetQuality({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 0});
  EXPECT_NEAR(inverted.volume, -1.0 / 6, kEps);
  EXPECT_LT(inverted.radius_ratio, 0);
}

TEST(MeshQuality, BoxReport) {
  const Eigen::Vector3d size(0.3, 0.2, 0.1);
  const TetMesh mesh = MakeBoxTetMesh({4, 3, 5}, size, {1, 2, 3});
  const MeshQualityReport r = CalcMeshQuality(mesh);
  EXPECT_EQ(r.num_nodes, 60);
  EXPECT_EQ(r.num_tets, mesh.num_tets());
  EXPECT_NEAR(r.total_volume, size.prod(), kEps * size.prod());
  EXPECT_NEAR(r.surface_volume, size.prod(), kEps * size.prod());
  EXPECT_EQ(r.num_inverted, 0);
  // all cells are 0.1 x 0.1 x 0.025 cuboids: every tet has the same volume
  EXPECT_NEAR(r.min_volume, size.prod() / mesh.num_tets(), 1e-15);
  EXPECT_NEAR(r.max_volume, size.prod() / mesh.num_tets(), 1e-15);
  EXPECT_NEAR(r.min_edge, 0.025, kEps);
  EXPECT_TRUE(r.bbox_min.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(r.bbox_max.isApprox(Eigen::Vector3d(1.3, 2.2, 3.1)));
  int histogram_total = 0;
  for (int c : r.radius_ratio_histogram) histogram_total += c;
  EXPECT_EQ(histogram_total, r.num_tets);
  EXPECT_FALSE(FormatMeshQuality(r).empty());
  // the same report on positions scaled by 1e3 and 1e-3: shape measures are unchanged
  for (double s : {1e-3, 1e3}) {
    const MeshQualityReport scaled = CalcMeshQuality(mesh, s * mesh.X);
    EXPECT_NEAR(scaled.min_radius_ratio, r.min_radius_ratio, 1e-12);
    EXPECT_NEAR(scaled.mean_edge_ratio, r.mean_edge_ratio, 1e-12);
    EXPECT_NEAR(scaled.total_volume, s * s * s * r.total_volume,
                1e-12 * s * s * s * r.total_volume);
  }
}

TEST(MeshQuality, CountsInvertedTetsOfADeformedState) {
  const TetMesh mesh = MakeBoxTetMesh({3, 3, 3}, {1, 1, 1});
  Eigen::Matrix3Xd x = mesh.X;
  // push the centre node through the top: the tets below it invert
  const int centre = 1 + 3 * (1 + 3 * 1);
  x(2, centre) = 1.5;
  const MeshQualityReport r = CalcMeshQuality(mesh, x);
  EXPECT_GT(r.num_inverted, 0);
  EXPECT_LT(r.min_volume, 0);
  const std::vector<double> v = CalcTetVolumes(mesh, x);
  int negative = 0;
  double sum = 0;
  for (double vi : v) {
    negative += vi <= 0;
    sum += vi;
  }
  EXPECT_EQ(negative, r.num_inverted);
  // moving an interior node does not change the total (signed) volume
  EXPECT_NEAR(sum, 1.0, kEps);
  EXPECT_NEAR(r.surface_volume, 1.0, kEps);
}

}  // namespace
}  // namespace nsim
