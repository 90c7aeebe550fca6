#include "common/mesh/point_locator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/mesh/tet_mesh.h"

namespace nsim {
namespace {

const Eigen::Vector3d kSize(0.3, 0.2, 0.1);
const Eigen::Vector3d kOrigin(-0.1, 0.05, 0.2);
// coordinates are computed from a 3x3 solve: rounding relative to the box size
const double kRelTol = 1e-12;

TetMesh Box() { return MakeBoxTetMesh({6, 5, 4}, kSize, kOrigin); }

Eigen::Vector3d RandomIn(std::mt19937& rng, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
}

TEST(TetLocator, RandomPointsInsideAreReproducedByTheirBarycentricCoordinates) {
  const TetMesh mesh = Box();
  const TetLocator locator(mesh);
  std::mt19937 rng(7);
  const double scale = kSize.norm();
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p = RandomIn(rng, kOrigin, kOrigin + kSize);
    const auto found = locator.Locate(p);
    ASSERT_TRUE(found.has_value()) << p.transpose();
    EXPECT_GE(found->bary.minCoeff(), -locator.tolerance());
    EXPECT_NEAR(found->bary.sum(), 1.0, kRelTol);
    EXPECT_LT((EvalTetPoint(mesh, mesh.X, *found) - p).norm(), kRelTol * scale);
    // an independent solve in the returned tet agrees
    const Eigen::Vector4i& t = mesh.tets[found->tet];
    const Eigen::Vector4d b =
        CalcBarycentric(p, mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]), mesh.X.col(t[3]));
    EXPECT_LT((b - found->bary).norm(), 1e-10);
  }
}

TEST(TetLocator, NodesAndFacePointsAreInside) {
  const TetMesh mesh = Box();
  const TetLocator locator(mesh);
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const auto found = locator.Locate(mesh.X.col(i));
    ASSERT_TRUE(found.has_value()) << i;
    EXPECT_LT((EvalTetPoint(mesh, mesh.X, *found) - mesh.X.col(i)).norm(), kRelTol * kSize.norm());
  }
  // centre of a boundary face
  const auto on_face =
      locator.Locate(kOrigin + Eigen::Vector3d(0.5 * kSize.x(), 0.5 * kSize.y(), 0));
  EXPECT_TRUE(on_face.has_value());
}

TEST(TetLocator, OutsidePointsAreReportedOutsideWithTheirClosestPoint) {
  const TetMesh mesh = Box();
  const TetLocator locator(mesh);
  std::mt19937 rng(11);
  const Eigen::Vector3d lo = kOrigin - kSize, hi = kOrigin + 2 * kSize;
  int outside = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p = RandomIn(rng, lo, hi);
    const Eigen::Vector3d clamped = p.cwiseMax(kOrigin).cwiseMin(kOrigin + kSize);
    const double distance = (p - clamped).norm();
    if (distance < 1e-9) continue;  // inside (or on the boundary)
    ++outside;
    EXPECT_FALSE(locator.Locate(p).has_value()) << p.transpose();
    double d = -1;
    const TetPoint closest = locator.LocateClosest(p, &d);
    ASSERT_GE(closest.tet, 0);
    EXPECT_GE(closest.bary.minCoeff(), 0.0);
    EXPECT_NEAR(closest.bary.sum(), 1.0, kRelTol);
    // the closest point of a box is the clamped point
    EXPECT_NEAR(d, distance, kRelTol * kSize.norm());
    EXPECT_LT((EvalTetPoint(mesh, mesh.X, closest) - clamped).norm(), 1e-10 * kSize.norm());
  }
  EXPECT_GT(outside, 1000);
  // just outside by more than the tolerance
  EXPECT_FALSE(locator.Locate(kOrigin - Eigen::Vector3d(1e-6, 0, 0) +
                              0.5 * Eigen::Vector3d(0, kSize.y(), kSize.z())));
}

TEST(TetLocator, LocateClosestOfAnInsidePointIsThePointItself) {
  const TetMesh mesh = Box();
  const TetLocator locator(mesh);
  const Eigen::Vector3d p = kOrigin + Eigen::Vector3d(0.11, 0.07, 0.03);
  double d = -1;
  const TetPoint tp = locator.LocateClosest(p, &d);
  EXPECT_EQ(d, 0.0);
  EXPECT_LT((EvalTetPoint(mesh, mesh.X, tp) - p).norm(), kRelTol * kSize.norm());
}

TEST(TetLocator, LocatesOnADeformedConfiguration) {
  const TetMesh mesh = Box();
  // affine map: barycentric coordinates are invariant, so the deformed point of a rest point
  // must be located with the rest point's coordinates
  Eigen::Matrix3d a;
  a << 1.2, 0.3, -0.1, 0.05, 0.9, 0.2, -0.2, 0.1, 1.1;
  ASSERT_GT(a.determinant(), 0);
  const Eigen::Vector3d shift(0.01, -0.2, 0.3);
  const Eigen::Matrix3Xd x = (a * mesh.X).colwise() + shift;
  const TetLocator rest(mesh), deformed(mesh, x);
  std::mt19937 rng(3);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d p = RandomIn(rng, kOrigin, kOrigin + kSize);
    const auto at_rest = rest.Locate(p);
    ASSERT_TRUE(at_rest.has_value());
    const Eigen::Vector3d q = a * p + shift;
    const auto moved = deformed.Locate(q);
    ASSERT_TRUE(moved.has_value());
    EXPECT_LT((EvalTetPoint(mesh, x, *moved) - q).norm(), kRelTol * 2 * kSize.norm());
    // the material point is the same (same tet unless p lies on a shared face)
    EXPECT_LT((EvalTetPoint(mesh, mesh.X, *moved) - p).norm(), 1e-10 * kSize.norm());
    // and the rest point evaluated on the deformed positions lands on q
    EXPECT_LT((EvalTetPoint(mesh, x, *at_rest) - q).norm(), 1e-10 * kSize.norm());
  }
  // the rest point near a corner is not inside the deformed mesh there
  EXPECT_FALSE(deformed.Locate(Eigen::Vector3d(-1, -1, -1)).has_value());
}

TEST(TetLocator, NonlinearDeformation) {
  const TetMesh mesh = MakeBoxTetMesh({9, 3, 3}, {1.0, 0.1, 0.1});
  // bend the bar around the z axis
  Eigen::Matrix3Xd x(3, mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const Eigen::Vector3d p = mesh.X.col(i);
    const double r = 1.0 + p.y(), angle = 0.8 * p.x();
    x.col(i) = Eigen::Vector3d(r * std::sin(angle), r * std::cos(angle), p.z());
  }
  const TetLocator locator(mesh, x);
  std::mt19937 rng(5);
  for (int i = 0; i < 500; ++i) {
    const TetPoint tp{static_cast<int>(rng() % mesh.num_tets()), Eigen::Vector4d::Zero()};
    Eigen::Vector4d w = Eigen::Vector4d::Random().cwiseAbs() + Eigen::Vector4d::Constant(0.01);
    TetPoint material{tp.tet, w / w.sum()};
    const Eigen::Vector3d q = EvalTetPoint(mesh, x, material);
    const auto found = locator.Locate(q);
    ASSERT_TRUE(found.has_value());
    EXPECT_LT((EvalTetPoint(mesh, x, *found) - q).norm(), 1e-12);
    // strictly inside one tet: the same tet and coordinates come back
    EXPECT_EQ(found->tet, material.tet);
    EXPECT_LT((found->bary - material.bary).norm(), 1e-10);
  }
}

}  // namespace
}  // namespace nsim
