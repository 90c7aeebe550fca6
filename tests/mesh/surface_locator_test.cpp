#include "common/mesh/surface_locator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "common/mesh/mesh_adjacency.h"
#include "common/mesh/tet_mesh.h"

namespace nsim {
namespace {

const Eigen::Vector3d kSize(0.3, 0.2, 0.1);
const Eigen::Vector3d kLo(-0.1, 0.05, 0.2);
const Eigen::Vector3d kHi = kLo + kSize;
const double kTol = 1e-12 * kSize.norm();  // m

TetMesh Box() { return MakeBoxTetMesh({6, 5, 4}, kSize, kLo); }

// analytic closest point of the box boundary and its outward normal
void BoxClosest(const Eigen::Vector3d& p, Eigen::Vector3d* closest, Eigen::Vector3d* normal,
                double* distance) {
  const Eigen::Vector3d clamped = p.cwiseMax(kLo).cwiseMin(kHi);
  if ((clamped - p).squaredNorm() > 0) {
    *closest = clamped;
    *distance = (clamped - p).norm();
    return;
  }
  // inside: the nearest face
  double best = 1e300;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const double d = side ? kHi[axis] - p[axis] : p[axis] - kLo[axis];
      if (d < best) {
        best = d;
        *closest = p;
        (*closest)[axis] = side ? kHi[axis] : kLo[axis];
        *normal = Eigen::Vector3d::Zero();
        (*normal)[axis] = side ? 1 : -1;
      }
    }
  *distance = best;
}

TEST(SurfaceLocator, ClosestPointMatchesTheBox) {
  const TetMesh mesh = Box();
  const SurfaceLocator surface(mesh);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p = kLo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(kSize);
    Eigen::Vector3d expected(0, 0, 0), normal(0, 0, 0);
    double distance;
    BoxClosest(p, &expected, &normal, &distance);
    const SurfacePoint s = surface.Closest(p);
    EXPECT_NEAR(s.distance, distance, kTol);
    EXPECT_LT((s.p - expected).norm(), 1e-10) << p.transpose();
    EXPECT_NEAR((s.p - p).norm(), s.distance, kTol);
    // the material point of the owning tet is the same point
    EXPECT_LT((EvalTetPoint(mesh, mesh.X, s.tet_point) - s.p).norm(), kTol);
    if (normal.squaredNorm() > 0) {
      EXPECT_LT((s.normal - normal).norm(), 1e-12);
      const double sd = surface.SignedDistance(p);
      EXPECT_NEAR(sd, -distance, kTol);
    } else {
      EXPECT_NEAR(surface.SignedDistance(p), distance, kTol);
    }
  }
}

TEST(SurfaceLocator, SegmentFirstHitMatchesTheBox) {
  const TetMesh mesh = Box();
  const SurfaceLocator surface(mesh);
  // a needle coming from -x towards the centre enters through the face x = lo.x
  const Eigen::Vector3d centre = 0.5 * (kLo + kHi);
  const Eigen::Vector3d a = centre - Eigen::Vector3d(0.5, 0.013, -0.007);
  const auto hit = surface.FirstHit(a, centre);
  ASSERT_TRUE(hit.has_value());
  const double t = (kLo.x() - a.x()) / (centre.x() - a.x());
  EXPECT_NEAR(hit->distance, t, 1e-12);
  EXPECT_LT((hit->p - (a + t * (centre - a))).norm(), kTol);
  EXPECT_LT((hit->normal - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((EvalTetPoint(mesh, mesh.X, hit->tet_point) - hit->p).norm(), kTol);
  // entering, the direction opposes the outward normal
  EXPECT_LT((centre - a).dot(hit->normal), 0);
  // the segment stopping short of the surface misses
  EXPECT_FALSE(surface.FirstHit(a, a + 0.9 * t * (centre - a)).has_value());
  // from inside going up leaves through z = hi.z
  const auto exit = surface.FirstHit(centre, centre + Eigen::Vector3d(0, 0, 1));
  ASSERT_TRUE(exit.has_value());
  EXPECT_NEAR(exit->p.z(), kHi.z(), kTol);
  EXPECT_NEAR(exit->distance, kHi.z() - centre.z(), 1e-12);
  EXPECT_GT(exit->normal.z(), 0.999);
  // a segment passing beside the box misses
  EXPECT_FALSE(
      surface.FirstHit(kLo - Eigen::Vector3d(0.1, 0.1, 0.1), kLo - Eigen::Vector3d(0.1, -0.5, 0.1))
          .has_value());
  // a degenerate segment hits nothing
  EXPECT_FALSE(surface.FirstHit(a, a).has_value());
}

TEST(SurfaceLocator, RaysThroughMeshEdgesAndVerticesStillHit) {
  const TetMesh mesh = Box();
  const SurfaceLocator surface(mesh);
  // grid spacing is 0.06 x 0.05 x 0.0333: aim at a surface node and at an edge midpoint
  const Eigen::Vector3d node = kLo + Eigen::Vector3d(0.12, 0.1, 0.0);
  const Eigen::Vector3d edge_mid = kLo + Eigen::Vector3d(0.15, 0.1, 0.0);
  for (const Eigen::Vector3d& target : {node, edge_mid}) {
    const Eigen::Vector3d origin = target - Eigen::Vector3d(0, 0, 0.2);
    const auto hit = surface.RayCast(origin, Eigen::Vector3d(0, 0, 1));
    ASSERT_TRUE(hit.has_value()) << target.transpose();
    EXPECT_NEAR(hit->distance, 0.2, 1e-12);
    EXPECT_LT((hit->p - target).norm(), kTol);
    EXPECT_GE(hit->bary.minCoeff(), 0.0);
  }
}

TEST(SurfaceLocator, FollowsDeformedPositions) {
  const TetMesh mesh = Box();
  const Eigen::Vector3d shift(0.05, 0, 0);
  const Eigen::Matrix3Xd x = mesh.X.colwise() + shift;
  const SurfaceLocator surface(mesh, x);
  const Eigen::Vector3d centre = 0.5 * (kLo + kHi) + shift;
  const auto hit = surface.FirstHit(centre - Eigen::Vector3d(1, 0, 0), centre);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->p.x(), kLo.x() + shift.x(), kTol);
  EXPECT_LT((EvalTetPoint(mesh, x, hit->tet_point) - hit->p).norm(), kTol);
  EXPECT_NEAR(surface.Closest(Eigen::Vector3d(kLo.x() - 0.1, centre.y(), centre.z())).distance,
              0.15, kTol);
}

// the owning tets given (MeshAdjacency::surface_tets, as the needle's contact search passes
// them) build the same locator as the face matching: every query answers the same, to the bit
TEST(SurfaceLocator, GivenOwnersAnswerLikeTheFaceMatching) {
  const TetMesh mesh = Box();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  Eigen::Matrix3Xd x = mesh.X;
  for (int i = 0; i < x.cols(); ++i)
    for (int k = 0; k < 3; ++k) x(k, i) += jitter(rng);
  const SurfaceLocator matched(mesh, x);
  const SurfaceLocator given(mesh, x, CalcMeshAdjacency(mesh).surface_tets);
  std::uniform_real_distribution<double> where(-0.2, 0.6);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d a(where(rng), where(rng), where(rng)), b(where(rng), where(rng), where(rng));
    const SurfacePoint c1 = matched.Closest(a), c2 = given.Closest(a);
    EXPECT_EQ(c1.triangle, c2.triangle);
    EXPECT_EQ(c1.tet_point.tet, c2.tet_point.tet);
    EXPECT_EQ(c1.tet_point.bary, c2.tet_point.bary);
    EXPECT_LT((EvalTetPoint(mesh, x, c2.tet_point) - c2.p).norm(), kTol);
    const auto h1 = matched.FirstHit(a, b), h2 = given.FirstHit(a, b);
    ASSERT_EQ(h1.has_value(), h2.has_value());
    if (h1) {
      EXPECT_EQ(h1->tet_point.tet, h2->tet_point.tet);
      EXPECT_EQ(h1->tet_point.bary, h2->tet_point.bary);
    }
  }
  // a wrong owner (a tet the triangle is no face of) or a wrong count is a programming error
  std::vector<int> wrong = CalcMeshAdjacency(mesh).surface_tets;
  const std::vector<int> short_list(wrong.begin(), wrong.end() - 1);
  EXPECT_DEATH(SurfaceLocator(mesh, x, short_list), "owning tets given");
  wrong[0] = wrong[0] == 0 ? mesh.num_tets() - 1 : 0;
  EXPECT_DEATH(SurfaceLocator(mesh, x, wrong), "is no face of tet");
}

}  // namespace
}  // namespace nsim
