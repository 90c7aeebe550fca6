#include "common/fem/tet_lanes.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "common/fem/corotational.h"

namespace nsim {
namespace {

// seven tets (a full block and a partial one) with random rest shapes, rotations, positions and
// velocities; the lane kernels against the one-element functions, the stiffness as the dense
// 12 x 12 R K_e R^T (a second formula: CalcCorotatedStiffness assembles K_ab block by block)
struct Elements {
  std::vector<Eigen::Vector4i> tets;
  std::vector<TetRestShape> rest;
  std::vector<Eigen::Matrix3d> rotation;
  std::vector<Matrix34d> x, w;
};

Elements RandomElements(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Elements el;
  for (int e = 0; e < count; ++e) {
    Matrix34d X;
    X << 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0;
    for (int i = 0; i < 12; ++i) X(i) += 0.3 * u(rng);
    X *= 0.01 * (1.0 + 0.5 * u(rng));
    if (Eigen::Matrix3d(X.rightCols<3>().colwise() - X.col(0)).determinant() < 0.0)
      X.col(1).swap(X.col(2));
    el.tets.emplace_back(4 * e, 4 * e + 1, 4 * e + 2, 4 * e + 3);
    el.rest.push_back(CalcTetRestShape(X));
    const Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    el.rotation.push_back(Eigen::AngleAxisd(3.0 * u(rng), axis.normalized()).toRotationMatrix());
    Matrix34d strain = Matrix34d::Random() * 1e-4;
    el.x.push_back(el.rotation.back() * X + strain);
    el.w.push_back(Matrix34d::Random() * 0.05);
  }
  return el;
}

TetLanes34 Gather(const std::vector<Matrix34d>& m, int block) {
  TetLanes34 lanes;
  for (int l = 0; l < kTetLanes; ++l) {
    const int e = std::min(kTetLanes * block + l, static_cast<int>(m.size()) - 1);
    for (int i = 0; i < 12; ++i) lanes[i][l] = m[e](i);
  }
  return lanes;
}

Eigen::Matrix<double, 12, 1> Stack(const Matrix34d& m) {
  return Eigen::Map<const Eigen::Matrix<double, 12, 1>>(m.data());
}

TEST(TetLanesTest, BlocksHoldTheTetsAndPadWithNothing) {
  const Elements el = RandomElements(7, 1);
  const TetBlocks blocks = MakeTetBlocks(el.tets, el.rest);
  ASSERT_EQ(blocks.num_blocks(), 2);
  EXPECT_EQ(blocks.num_tets, 7);
  for (int e = 0; e < 8; ++e) {
    const int b = e / kTetLanes, l = e % kTetLanes;
    if (e < 7) {
      EXPECT_EQ(blocks.nodes[b][l], el.tets[e]);
      EXPECT_EQ(blocks.volume[b][l], el.rest[e].volume);
      for (int i = 0; i < 12; ++i) EXPECT_EQ(blocks.grad[b][i][l], el.rest[e].grad_n(i));
    } else {
      EXPECT_EQ(blocks.nodes[b][l], el.tets[4]);  // a valid node to gather from
      EXPECT_EQ(blocks.volume[b][l], 0.0);
      for (int i = 0; i < 12; ++i) EXPECT_EQ(blocks.grad[b][i][l], 0.0);
    }
  }
}

TEST(TetLanesTest, GatherScatterAndElementOfMatchTheTets) {
  const Elements el = RandomElements(7, 3);
  const TetBlocks blocks = MakeTetBlocks(el.tets, el.rest);
  const Eigen::Matrix3Xd nodal = Eigen::Matrix3Xd::Random(3, 28);
  Eigen::Matrix3Xd sum = Eigen::Matrix3Xd::Zero(3, 28);
  std::vector<TetLanes34> lanes;
  for (int b = 0; b < blocks.num_blocks(); ++b) {
    const TetLanes34 u = GatherLanes(blocks, b, nodal);
    for (int l = 0; l < kTetLanes; ++l)
      for (int a = 0; a < 4; ++a)
        for (int c = 0; c < 3; ++c)
          EXPECT_EQ(u[3 * a + c][l], nodal(c, blocks.nodes[b][l][a])) << b << " " << l;
    ScatterAddLanes(blocks, b, u, sum);  // each node belongs to one tet here: sum = nodal there
    lanes.push_back(u);
  }
  // the padding lane (element 7) adds nothing: every node of the 7 tets once, no node twice
  EXPECT_EQ(sum, nodal);
  for (int e = 0; e < 7; ++e) {
    const Matrix34d m = ElementOfLanes(lanes, e);
    for (int a = 0; a < 4; ++a) EXPECT_EQ(Eigen::Vector3d(m.col(a)), nodal.col(el.tets[e][a])) << e;
  }
}

TEST(TetLanesTest, StressLanesEqualTheElementStiffnessAndStepLoad) {
  const Elements el = RandomElements(7, 2);
  const TetBlocks blocks = MakeTetBlocks(el.tets, el.rest);
  const LameParameters lame = CalcLameParameters(5500.0, 0.45);
  const double h = 0.02, c = 0.02 * 0.01 + 0.02 * 0.02;
  for (int b = 0; b < blocks.num_blocks(); ++b) {
    TetLanes33 rotation;
    for (int l = 0; l < kTetLanes; ++l) {
      const int e = std::min(kTetLanes * b + l, 6);
      for (int i = 0; i < 9; ++i) rotation[i][l] = el.rotation[e](i);
    }
    const TetLanes34 r = RotateLanes(rotation, blocks.grad[b]);
    const TetLanes34 x = Gather(el.x, b), w = Gather(el.w, b);
    const TetLanes34 ku = ApplyStressLanes(r, blocks.volume[b], lame, 0.0, w);
    TetLanes34 hx_cw;
    for (int i = 0; i < 12; ++i) hx_cw[i] = h * x[i] + c * w[i];
    const TetLanes34 load = ApplyStressLanes(r, -blocks.volume[b], lame, h, hx_cw);
    for (int l = 0; l < kTetLanes; ++l) {
      const int e = kTetLanes * b + l;
      if (e >= 7) {  // padding: nothing
        for (int i = 0; i < 12; ++i) EXPECT_EQ(ku[i][l], 0.0);
        for (int i = 0; i < 12; ++i) EXPECT_EQ(load[i][l], 0.0);
        continue;
      }
      const Eigen::Matrix3d& R = el.rotation[e];
      const Matrix34d r_one = R * el.rest[e].grad_n;
      for (int i = 0; i < 12; ++i) EXPECT_NEAR(r[i][l], r_one(i), 1e-13 * r_one.norm()) << e;
      const Eigen::Matrix<double, 12, 1> k_ref =
          CalcCorotatedStiffness(el.rest[e], lame, R) * Stack(el.w[e]);
      const Eigen::Matrix3d F = CalcDeformationGradient(el.rest[e], el.x[e]);
      const Eigen::Matrix<double, 12, 1> load_ref =
          h * Stack(CalcCorotatedForce(el.rest[e], lame, R, F)) - c * k_ref;
      Eigen::Matrix<double, 12, 1> k_lanes, load_lanes;
      for (int i = 0; i < 12; ++i) k_lanes[i] = ku[i][l], load_lanes[i] = load[i][l];
      EXPECT_LT((k_lanes - k_ref).norm(), 1e-12 * k_ref.norm()) << e;
      EXPECT_LT((load_lanes - load_ref).norm(), 1e-11 * load_ref.norm()) << e;
      // and the one-element step load, the formula the lanes replace in FemSolver
      const Matrix34d one = CalcCorotatedStepLoad(el.rest[e], lame, r_one, el.x[e], el.w[e], h, c);
      EXPECT_LT((load_lanes - Stack(one)).norm(), 1e-12 * one.norm()) << e;
    }
  }
}

}  // namespace
}  // namespace nsim
