#include "common/mesh/triangle_geometry.h"

#include <gtest/gtest.h>

#include <random>

namespace nsim {
namespace {

TEST(TriangleGeometry, ClosestPointIsNoFartherThanAnySample) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)),
        c(u(rng), u(rng), u(rng));
    const Eigen::Vector3d p = 2 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d w = ClosestPointOnTriangle(p, a, b, c);
    EXPECT_GE(w.minCoeff(), -1e-15);
    EXPECT_NEAR(w.sum(), 1.0, 1e-14);
    const double d = (w[0] * a + w[1] * b + w[2] * c - p).norm();
    const int n = 60;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Eigen::Vector3d s = a + (b - a) * i / n + (c - a) * j / n;
        EXPECT_LE(d, (s - p).norm() + 1e-12);
      }
  }
}

TEST(TriangleGeometry, ClosestPointAnalyticCases) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(
      ClosestPointOnTriangle({0.2, 0.3, 5}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.2, 0.3)));
  EXPECT_TRUE(ClosestPointOnTriangle({-1, -1, 0}, a, b, c).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(ClosestPointOnTriangle({1, 1, 0}, a, b, c).isApprox(Eigen::Vector3d(0, 0.5, 0.5)));
  // degenerate (collinear) triangle: the closest point of the segment
  const Eigen::Vector3d w = ClosestPointOnTriangle({0.5, 1, 0}, a, b, Eigen::Vector3d(2, 0, 0));
  EXPECT_TRUE(
      (w[0] * a + w[1] * b + w[2] * Eigen::Vector3d(2, 0, 0)).isApprox(Eigen::Vector3d(0.5, 0, 0)));
}

TEST(TriangleGeometry, RayIntersection) {
  const Eigen::Vector3d a(0, 0, 1), b(1, 0, 1), c(0, 1, 1);
  double t;
  Eigen::Vector3d w;
  ASSERT_TRUE(IntersectRayTriangle({0.25, 0.25, 0}, {0, 0, 2}, a, b, c, &t, &w));
  EXPECT_DOUBLE_EQ(t, 0.5);
  EXPECT_TRUE(w.isApprox(Eigen::Vector3d(0.5, 0.25, 0.25)));
  // behind the origin: negative t
  ASSERT_TRUE(IntersectRayTriangle({0.25, 0.25, 2}, {0, 0, 1}, a, b, c, &t, &w));
  EXPECT_DOUBLE_EQ(t, -1.0);
  EXPECT_FALSE(IntersectRayTriangle({0.75, 0.75, 0}, {0, 0, 1}, a, b, c, &t, &w));  // beside
  EXPECT_FALSE(IntersectRayTriangle({0.25, 0.25, 0}, {1, 0, 0}, a, b, c, &t, &w));  // parallel
  // exactly on an edge
  EXPECT_TRUE(IntersectRayTriangle({0.5, 0.5, 0}, {0, 0, 1}, a, b, c, &t, &w));
}

}  // namespace
}  // namespace nsim
