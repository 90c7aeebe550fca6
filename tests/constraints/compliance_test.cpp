#include "common/constraints/compliance.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <random>

#include "common/constraints/dense_linear_body.h"
#include "tests/constraints/test_helpers.h"

namespace nsim {
namespace {

using testing::MakeChainConfig;

constexpr double kAgreement = 1e-11;  // relative: two paths to the same matrix

// dense H_b (rows x 3 n_b) of one body, straight from the row definition
Eigen::MatrixXd DenseH(const ConstraintSet& set, int body) {
  const int n = set.body(body).num_nodes();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(set.num_rows(), 3 * n);
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) {
      const ConstraintPoint& p = set.point(set.term(t).point);
      if (p.body != body) continue;
      for (int k = 0; k < p.num_nodes; ++k) {
        const int node = set.point_nodes()[p.first_node + k];
        H.block<1, 3>(i, 3 * node) +=
            set.point_weights()[p.first_node + k] * set.term(t).direction.transpose();
      }
    }
  }
  return H;
}

// h^2 A^-1 by explicit inversion
Eigen::MatrixXd DenseCompliance(const DenseLinearBody& b) {
  return b.time_step() * b.time_step() * b.system_matrix().inverse();
}

struct TwoBodies {
  DenseLinearBody a{MakeChainConfig(5, 0.1, 0.02, 60.0, 0.01, Eigen::Vector3d::Zero(),
                                    Eigen::Vector3d(0, 0, -9.81))};
  DenseLinearBody b{MakeChainConfig(4, 0.3, 0.03, 30.0, 0.01, Eigen::Vector3d(0, 0.05, 0),
                                    Eigen::Vector3d(0, 0, -9.81))};

  // random barycentric points, rows over one or two bodies and kinematic points
  void Build(ConstraintSet& set, std::uint64_t key_base, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.05, 1.0), d(-1.0, 1.0);
    set.Clear();
    const int ia = set.AddBody(a), ib = set.AddBody(b);
    auto random_point = [&](int body, int n, std::uint64_t key) {
      std::vector<int> nodes{0, 1, 2, 3};
      for (int& k : nodes) k = static_cast<int>(rng() % n);
      std::vector<double> w{u(rng), u(rng), u(rng), u(rng)};
      const double sum = w[0] + w[1] + w[2] + w[3];
      for (double& x : w) x /= sum;
      return set.AddBodyPoint(body, nodes, w, key);
    };
    auto random_dir = [&]() { return Eigen::Vector3d(d(rng), d(rng), d(rng)).normalized(); };
    auto key = [&](std::uint64_t k) { return key_base ? key_base + k : 0; };
    const int pa0 = random_point(ia, 5, key(1)), pa1 = random_point(ia, 5, key(2));
    const int pb0 = random_point(ib, 4, key(3));
    const int kin = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.01, 0, 0));
    set.AddBilateral(pa0, pb0, Eigen::Matrix3d::Identity());
    set.AddFrictionContact(pa1, kin, random_dir(), 0.3);
    set.AddContact(pb0, pa1, random_dir());
    // a row with three terms on two bodies
    set.AddRow({{pa0, random_dir()}, {pa1, random_dir()}, {pb0, random_dir()}}, 0.0);
    set.AddGroup(ConstraintLaw::kBilateral, 1);
  }
};

TEST(ComplianceTest, SparseAssemblyEqualsDenseHAinvHt) {
  TwoBodies bodies;
  ConstraintSet set;
  bodies.Build(set, 0, 42);
  ComplianceAssembler assembler;
  Eigen::MatrixXd W;
  assembler.Assemble(set, W);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(set.num_rows(), set.num_rows());
  for (int b = 0; b < 2; ++b) {
    const Eigen::MatrixXd H = DenseH(set, b);
    expected += H * DenseCompliance(b == 0 ? bodies.a : bodies.b) * H.transpose();
  }
  ASSERT_EQ(W.rows(), 8);
  EXPECT_LE((W - expected).norm(), kAgreement * expected.norm());
  EXPECT_EQ(assembler.stats().num_body_points, 3);
  EXPECT_EQ(assembler.stats().num_solved_columns, 9);

  // corrections: dx_b = C_b H_b^T lambda
  const Eigen::VectorXd lambda = Eigen::VectorXd::LinSpaced(set.num_rows(), -1.0, 2.0);
  std::vector<Eigen::Matrix3Xd> dx;
  assembler.CalcCorrections(set, lambda, dx);
  for (int b = 0; b < 2; ++b) {
    const Eigen::VectorXd ref =
        DenseCompliance(b == 0 ? bodies.a : bodies.b) * DenseH(set, b).transpose() * lambda;
    const Eigen::Map<const Eigen::VectorXd> got(dx[b].data(), dx[b].size());
    EXPECT_LE((got - ref).norm(), kAgreement * ref.norm());
  }
}

TEST(ComplianceTest, KeyedPointsReuseColumnsWhileComplianceUnchanged) {
  TwoBodies bodies;
  ConstraintSet set;
  ComplianceAssembler assembler;
  Eigen::MatrixXd W1, W2, W3;
  bodies.Build(set, 100, 7);
  assembler.Assemble(set, W1);
  EXPECT_EQ(assembler.stats().num_solved_columns, 9);
  EXPECT_EQ(assembler.stats().num_reused_points, 0);
  // same points (same keys), next step: nothing is solved, W is identical
  bodies.Build(set, 100, 7);
  assembler.Assemble(set, W2);
  EXPECT_EQ(assembler.stats().num_solved_columns, 0);
  EXPECT_EQ(assembler.stats().num_reused_points, 3);
  EXPECT_EQ((W1 - W2).norm(), 0.0);
  // a new step size changes body a's compliance: its two points are solved again
  bodies.a.set_time_step(0.02);
  assembler.Assemble(set, W3);
  EXPECT_EQ(assembler.stats().num_solved_columns, 6);
  EXPECT_EQ(assembler.stats().num_reused_points, 1);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(set.num_rows(), set.num_rows());
  for (int b = 0; b < 2; ++b) {
    const Eigen::MatrixXd H = DenseH(set, b);
    expected += H * DenseCompliance(b == 0 ? bodies.a : bodies.b) * H.transpose();
  }
  EXPECT_LE((W3 - expected).norm(), kAgreement * expected.norm());
  // the same keys now naming other points (other seed): recomputed, not served stale
  bodies.Build(set, 100, 8);
  assembler.Assemble(set, W3);
  EXPECT_EQ(assembler.stats().num_solved_columns, 9);
  expected.setZero(set.num_rows(), set.num_rows());
  for (int b = 0; b < 2; ++b) {
    const Eigen::MatrixXd H = DenseH(set, b);
    expected += H * DenseCompliance(b == 0 ? bodies.a : bodies.b) * H.transpose();
  }
  EXPECT_LE((W3 - expected).norm(), kAgreement * expected.norm());
}

TEST(ComplianceTest, IdleEntriesAreEvicted) {
  TwoBodies bodies;
  ConstraintSet keyed, other;
  ComplianceAssembler assembler;
  Eigen::MatrixXd W;
  bodies.Build(keyed, 100, 1);
  assembler.Assemble(keyed, W);
  // rows on unkeyed points only, for kMaxIdleAssembles steps: keyed entries stay
  bodies.Build(other, 0, 2);
  for (int i = 0; i < ComplianceAssembler::kMaxIdleAssembles; ++i) assembler.Assemble(other, W);
  assembler.Assemble(keyed, W);
  EXPECT_EQ(assembler.stats().num_reused_points, 3);
  // one more idle assemble than allowed: evicted, solved again
  for (int i = 0; i <= ComplianceAssembler::kMaxIdleAssembles; ++i) assembler.Assemble(other, W);
  assembler.Assemble(keyed, W);
  EXPECT_EQ(assembler.stats().num_reused_points, 0);
  EXPECT_EQ(assembler.stats().num_solved_columns, 9);
}

}  // namespace
}  // namespace nsim
