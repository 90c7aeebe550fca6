#include "common/mesh/tet_point.h"

#include <gtest/gtest.h>

namespace nsim {
namespace {

TEST(TetPoint, BarycentricCoordinatesReproduceThePoint) {
  const Eigen::Vector3d a(0.1, 0, 0), b(1, 0.2, 0), c(0, 1, 0.3), d(0.2, 0.1, 1);
  const Eigen::Vector3d p(0.3, 0.25, 0.2);
  const Eigen::Vector4d w = CalcBarycentric(p, a, b, c, d);
  EXPECT_NEAR(w.sum(), 1.0, 1e-15);
  EXPECT_LT((w[0] * a + w[1] * b + w[2] * c + w[3] * d - p).norm(), 1e-15);
  // vertices have unit coordinates
  EXPECT_TRUE(CalcBarycentric(c, a, b, c, d).isApprox(Eigen::Vector4d(0, 0, 1, 0)));
  // a point outside has a negative coordinate
  EXPECT_LT(CalcBarycentric(Eigen::Vector3d(-1, -1, -1), a, b, c, d).minCoeff(), 0);
}

TEST(TetPoint, EvaluatesOnAnyPositions) {
  const TetMesh mesh = MakeBoxTetMesh({2, 2, 2}, {1, 1, 1});
  const TetPoint tp{3, Eigen::Vector4d(0.1, 0.2, 0.3, 0.4)};
  const Eigen::Vector4i& t = mesh.tets[3];
  const Eigen::Matrix3Xd x = 2.0 * mesh.X;
  Eigen::Vector3d expected = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) expected += tp.bary[k] * x.col(t[k]);
  EXPECT_TRUE(EvalTetPoint(mesh, x, tp).isApprox(expected));
  EXPECT_TRUE(EvalTetPoint(mesh, x, tp).isApprox(2.0 * EvalTetPoint(mesh, mesh.X, tp)));
}

}  // namespace
}  // namespace nsim
