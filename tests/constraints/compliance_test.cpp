#include "common/constraints/compliance.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
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

// distinct nodes of the body points used on `body` (a keyed point solves its nodes' columns)
int DistinctNodes(const ConstraintSet& set, int body) {
  std::vector<int> nodes;
  for (int p = 0; p < set.num_points(); ++p) {
    const ConstraintPoint& pt = set.point(p);
    if (pt.body != body) continue;
    nodes.insert(nodes.end(), set.point_nodes().begin() + pt.first_node,
                 set.point_nodes().begin() + pt.first_node + pt.num_nodes);
  }
  std::sort(nodes.begin(), nodes.end());
  return static_cast<int>(std::unique(nodes.begin(), nodes.end()) - nodes.begin());
}

// h^2 A^-1 by explicit inversion
Eigen::MatrixXd DenseCompliance(const DenseLinearBody& b) {
  return b.time_step() * b.time_step() * b.system_matrix().inverse();
}

// sum over the two bodies of H_b C_b H_b^T, dense
Eigen::MatrixXd DenseW(const ConstraintSet& set, const DenseLinearBody& a,
                       const DenseLinearBody& b) {
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(set.num_rows(), set.num_rows());
  for (int k = 0; k < 2; ++k) {
    const Eigen::MatrixXd H = DenseH(set, k);
    W += H * DenseCompliance(k == 0 ? a : b) * H.transpose();
  }
  return W;
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
  const int nodes_a = DistinctNodes(set, 0), nodes_b = DistinctNodes(set, 1);
  EXPECT_EQ(assembler.stats().num_solved_columns, 3 * (nodes_a + nodes_b));
  EXPECT_EQ(assembler.stats().num_reused_points, 0);
  // same points (same keys), next step: nothing is solved, W is identical
  bodies.Build(set, 100, 7);
  assembler.Assemble(set, W2);
  EXPECT_EQ(assembler.stats().num_solved_columns, 0);
  EXPECT_EQ(assembler.stats().num_reused_points, 3);
  EXPECT_EQ((W1 - W2).norm(), 0.0);
  // a new step size changes body a's compliance: the nodes of its two points are solved again
  bodies.a.set_time_step(0.02);
  assembler.Assemble(set, W3);
  EXPECT_EQ(assembler.stats().num_solved_columns, 3 * nodes_a);
  EXPECT_EQ(assembler.stats().num_reused_points, 1);
  EXPECT_LE((W3 - DenseW(set, bodies.a, bodies.b)).norm(),
            kAgreement * DenseW(set, bodies.a, bodies.b).norm());
  // the same keys now naming other points (other seed): combined from the node columns, exact
  bodies.Build(set, 100, 8);
  assembler.Assemble(set, W3);
  const Eigen::MatrixXd expected = DenseW(set, bodies.a, bodies.b);
  EXPECT_LE((W3 - expected).norm(), kAgreement * expected.norm());
}

// Prefetch solves node columns ahead of the Assemble that uses them, at most max_new_nodes a
// call (the first of the list not cached), and the Assemble then solves nothing and gives the
// W of an assembler that solved them itself; a compliance change drops what was prefetched
TEST(ComplianceTest, PrefetchedNodesAreNotSolvedAgain) {
  TwoBodies bodies;
  ConstraintSet set;
  bodies.Build(set, 100, 7);
  ComplianceAssembler ahead, plain;
  const std::vector<int> nodes_a{4, 3, 2, 1, 0, 3}, nodes_b{0, 1, 2, 3};
  EXPECT_EQ(ahead.Prefetch(bodies.a, nodes_a, 2), 6);  // 4 and 3
  EXPECT_EQ(ahead.Prefetch(bodies.a, nodes_a, 2), 6);  // 2 and 1
  EXPECT_EQ(ahead.Prefetch(bodies.a, nodes_a, 2), 3);  // 0
  EXPECT_EQ(ahead.Prefetch(bodies.a, nodes_a, 2), 0);
  EXPECT_EQ(ahead.Prefetch(bodies.b, nodes_b), 12);
  Eigen::MatrixXd W_ahead, W_plain;
  ahead.Assemble(set, W_ahead);
  EXPECT_EQ(ahead.stats().num_solved_columns, 0);
  plain.Assemble(set, W_plain);
  EXPECT_GT(plain.stats().num_solved_columns, 0);
  EXPECT_LE((W_ahead - W_plain).norm(), kAgreement * W_plain.norm());
  const Eigen::MatrixXd expected = DenseW(set, bodies.a, bodies.b);
  EXPECT_LE((W_ahead - expected).norm(), kAgreement * expected.norm());
  // body a's compliance changes: its prefetched columns are stale and solved again
  bodies.a.set_time_step(0.02);
  EXPECT_EQ(ahead.Prefetch(bodies.a, nodes_a), 15);
  EXPECT_EQ(ahead.Prefetch(bodies.b, nodes_b), 0);
  ahead.Assemble(set, W_ahead);
  EXPECT_EQ(ahead.stats().num_solved_columns, 0);
  const Eigen::MatrixXd changed = DenseW(set, bodies.a, bodies.b);
  EXPECT_LE((W_ahead - changed).norm(), kAgreement * changed.norm());
}

TEST(ComplianceTest, MovingKeyedPointNeedsNoSolveWithinKnownNodes) {
  // a needle tip moving inside a tet: same nodes, new weights every step
  TwoBodies bodies;
  ComplianceAssembler assembler;
  ConstraintSet set;
  Eigen::MatrixXd W;
  for (int step = 0; step < 5; ++step) {
    set.Clear();
    const int ia = set.AddBody(bodies.a);
    const double s = 0.1 + 0.15 * step;
    const int tip = set.AddBodyPoint(ia, std::vector<int>{0, 1, 3, 4},
                                     std::vector<double>{s, 0.5 - 0.5 * s, 0.2, 0.3 - 0.5 * s}, 9);
    const int goal = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    set.AddBilateral(tip, goal, Eigen::Matrix3d::Identity());
    assembler.Assemble(set, W);
    EXPECT_EQ(assembler.stats().num_solved_columns, step == 0 ? 12 : 0) << "step " << step;
    const Eigen::MatrixXd H = DenseH(set, 0);
    const Eigen::MatrixXd expected = H * DenseCompliance(bodies.a) * H.transpose();
    EXPECT_LE((W - expected).norm(), kAgreement * expected.norm()) << "step " << step;
  }
  // into the next tet: only its new node is solved
  set.Clear();
  const int ia = set.AddBody(bodies.a);
  const int tip = set.AddBodyPoint(ia, std::vector<int>{1, 2, 3, 4},
                                   std::vector<double>{0.25, 0.25, 0.25, 0.25}, 9);
  set.AddBilateral(tip, set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()),
                   Eigen::Matrix3d::Identity());
  assembler.Assemble(set, W);
  EXPECT_EQ(assembler.stats().num_solved_columns, 3);
}

TEST(ComplianceTest, KeyedPointsOfAnEverChangingComplianceSolveTheirOwnColumns) {
  // a body refactorized every step: node columns would be thrown away at once
  TwoBodies bodies;
  ComplianceAssembler assembler;
  ConstraintSet set;
  Eigen::MatrixXd W;
  for (int step = 0; step < 4; ++step) {
    bodies.a.set_time_step(0.01 + 0.001 * step);
    set.Clear();
    const int ia = set.AddBody(bodies.a);
    const int tip = set.AddBodyPoint(ia, std::vector<int>{0, 1, 3, 4},
                                     std::vector<double>{0.1, 0.2, 0.3, 0.4}, 9);
    set.AddBilateral(tip, set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()),
                     Eigen::Matrix3d::Identity());
    assembler.Assemble(set, W);
    // first assemble: node columns (12); from the second change in a row on: the point's own 3
    EXPECT_EQ(assembler.stats().num_solved_columns, step == 0 ? 12 : 3) << "step " << step;
    const Eigen::MatrixXd H = DenseH(set, 0);
    const Eigen::MatrixXd expected = H * DenseCompliance(bodies.a) * H.transpose();
    EXPECT_LE((W - expected).norm(), kAgreement * expected.norm()) << "step " << step;
  }
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
  EXPECT_EQ(assembler.stats().num_solved_columns,
            3 * (DistinctNodes(keyed, 0) + DistinctNodes(keyed, 1)));
}

}  // namespace
}  // namespace nsim
