#include "common/prediction/pca_buffer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace nsim {
namespace {

// samples along u around c with a small deterministic perpendicular wobble along w
PcaBuffer MakeLineBuffer(const Eigen::Vector3d& c, const Eigen::Vector3d& u,
                         const Eigen::Vector3d& w, double wobble, int n) {
  PcaBuffer buffer(n);
  for (int i = 0; i < n; ++i) {
    const double s = 0.01 * std::sin(0.37 * i) + 0.004 * std::cos(1.3 * i);
    buffer.Push(0.03 * i, c + s * u + wobble * std::sin(2.9 * i + 1) * w);
  }
  return buffer;
}

TEST(PcaBuffer, RecoversAKnownDirectionWithThePositiveLargestComponent) {
  const Eigen::Vector3d c(0.12, -0.3, 1.5);  // far from the origin: no cancellation issue
  const Eigen::Vector3d u = Eigen::Vector3d(0.2, -0.3, 0.93).normalized();
  const Eigen::Vector3d w = u.unitOrthogonal();
  PrincipalAxes axes;
  MakeLineBuffer(c, u, w, 1e-4, 300).CalcPrincipalAxes(&axes);
  // the wobble is 1 % of the motion: the direction is off by about (1e-4 / 1e-2)^2 at most
  EXPECT_GT(axes.directions.col(0).dot(u), 1 - 1e-3);
  EXPECT_GT(axes.singular_values[0], 10 * axes.singular_values[1]);
  EXPECT_GE(axes.singular_values[1], axes.singular_values[2]);
  EXPECT_NEAR((axes.directions.transpose() * axes.directions - Eigen::Matrix3d::Identity()).norm(),
              0, 1e-12);

  // a direction whose largest component is negative comes out flipped
  const Eigen::Vector3d v = Eigen::Vector3d(0.1, -0.9, 0.3).normalized();
  MakeLineBuffer(c, v, v.unitOrthogonal(), 0.0, 100).CalcPrincipalAxes(&axes);
  EXPECT_NEAR((axes.directions.col(0) + v).norm(), 0, 1e-9);
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d d = axes.directions.col(k);
    Eigen::Index i;
    d.cwiseAbs().maxCoeff(&i);
    EXPECT_GT(d[i], 0) << "column " << k;
  }
}

TEST(PcaBuffer, ExactLineHasOneSingularValueAndProjectsBack) {
  const Eigen::Vector3d c(0.5, 0.5, 0.5), u = Eigen::Vector3d(1, 2, 2) / 3.0;
  const PcaBuffer buffer = MakeLineBuffer(c, u, u.unitOrthogonal(), 0.0, 50);
  PrincipalAxes axes;
  buffer.CalcPrincipalAxes(&axes);
  // s1 = sqrt(sum of squared centred offsets along u)
  double mean_s = 0, ss = 0;
  for (int i = 0; i < 50; ++i) mean_s += u.dot(buffer.position(i) - c) / 50;
  for (int i = 0; i < 50; ++i) ss += std::pow(u.dot(buffer.position(i) - c) - mean_s, 2);
  const double scale = 0.01;  // size of the motion (m)
  EXPECT_NEAR(axes.singular_values[0], std::sqrt(ss), 1e-12 * scale);
  // the zero singular values come from eigenvalues of the scatter: error ~ sqrt(eps) s1
  EXPECT_NEAR(axes.singular_values[1], 0, 10 * std::sqrt(2.2e-16) * axes.singular_values[0]);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p = buffer.position(i);
    EXPECT_LE((axes.Reproject(axes.Project(p)) - p).norm(), 1e-14 * (1 + c.norm()));
  }
}

TEST(PcaBuffer, RingKeepsTheNewestSamplesInOrder) {
  PcaBuffer buffer(4);
  EXPECT_EQ(buffer.capacity(), 4);
  for (int i = 0; i < 6; ++i) buffer.Push(i, Eigen::Vector3d(i, 0, 0));
  EXPECT_TRUE(buffer.full());
  EXPECT_EQ(buffer.size(), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(buffer.time(i), i + 2);
    EXPECT_EQ(buffer.position(i).x(), i + 2);
  }
  EXPECT_EQ(buffer.newest_time(), 5);
  PrincipalAxes axes;
  buffer.CalcPrincipalAxes(&axes);
  EXPECT_DOUBLE_EQ(axes.mean.x(), 3.5);  // mean of 2, 3, 4, 5 only
  EXPECT_NEAR(axes.directions.col(0).x(), 1.0, 1e-12);
  buffer.Clear();
  EXPECT_EQ(buffer.size(), 0);
}

}  // namespace
}  // namespace nsim
