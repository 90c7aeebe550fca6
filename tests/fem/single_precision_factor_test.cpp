// The single-precision supernodal solve (common/fem/single_precision_factor.h) against the
// double-precision CHOLMOD solve and a dense LLT, and the FEM solver's conjugate gradient with it
// against the same solver with the double preconditioner.

#include "common/fem/single_precision_factor.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>

#include "common/fem/cholmod_factor.h"
#include "common/fem/fem_solver.h"
#include "common/mesh/gmsh_reader.h"

namespace nsim {
namespace {

constexpr double kFloatEpsilon = 5.96e-8;  // 2^-24, the unit round-off of float

// a 7-point 3D Laplacian on an n^3 grid plus `shift` on the diagonal: a nested-dissection
// ordering gives supernodes of many sizes (a tree of separators), as on a tet mesh
Eigen::SparseMatrix<double> GridLaplacian(int n, double shift) {
  std::vector<Eigen::Triplet<double>> entries;
  auto index = [n](int i, int j, int k) { return (i * n + j) * n + k; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const int a = index(i, j, k);
        entries.emplace_back(a, a, 6.0 + shift);
        const int neighbours[3][3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (const auto& q : neighbours) {
          if (q[0] >= n || q[1] >= n || q[2] >= n) continue;
          const int b = index(q[0], q[1], q[2]);
          entries.emplace_back(a, b, -1.0);
          entries.emplace_back(b, a, -1.0);
        }
      }
  Eigen::SparseMatrix<double> A(n * n * n, n * n * n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

TEST(SinglePrecisionFactorTest, SolvesToFloatAccuracyLikeTheDoubleFactor) {
  for (double shift : {1.0, 0.01}) {  // cond(A) about 13 and 1100
    const Eigen::SparseMatrix<double> A = GridLaplacian(10, shift);
    CholmodFactor factor;
    factor.Analyze(A);
    ASSERT_TRUE(factor.Factorize(A));
    SinglePrecisionFactor single;
    single.Assign(factor.supernodal_view());
    ASSERT_EQ(single.rows(), A.rows());
    const Eigen::MatrixXd dense(A);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dense);
    const double cond = eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
    const Eigen::LLT<Eigen::MatrixXd> llt(dense);
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::VectorXd b = Eigen::VectorXd::Random(A.rows());
      const Eigen::VectorXd reference = llt.solve(b);
      Eigen::VectorXd x(A.rows()), x_double(A.rows());
      single.Solve(b, x);
      factor.Solve(b, x_double);
      const double error = (x - reference).norm() / reference.norm();
      const double residual = (A * x - b).norm() / b.norm();
      // forward error of a float triangular solve pair: a modest multiple of cond x eps_float
      EXPECT_LT(error, 10.0 * cond * kFloatEpsilon) << "shift " << shift;
      EXPECT_LT(residual, 100.0 * kFloatEpsilon) << "shift " << shift;
      // and it is a float solve, not the double one in disguise
      EXPECT_GT((x - x_double).norm() / reference.norm(), 1e-12);
      EXPECT_LT((x_double - reference).norm() / reference.norm(), 1e-13);
    }
  }
}

TEST(SinglePrecisionFactorTest, FollowsRefactorizationsAndRefusesMisuse) {
  Eigen::SparseMatrix<double> A = GridLaplacian(6, 0.5);
  CholmodFactor factor;
  factor.Analyze(A);
  EXPECT_DEATH(factor.supernodal_view(), "without a valid factorization");
  ASSERT_TRUE(factor.Factorize(A));
  SinglePrecisionFactor single;
  EXPECT_TRUE(single.empty());
  Eigen::VectorXd b = Eigen::VectorXd::Ones(A.rows()), x(A.rows());
  EXPECT_DEATH(single.Solve(b, x), "without a factor");
  single.Assign(factor.supernodal_view());
  single.Solve(b, x);
  const Eigen::VectorXd first = x;
  // new values, same pattern: a new copy solves the new system
  for (int k = 0; k < A.nonZeros(); ++k) A.valuePtr()[k] *= 4.0;
  ASSERT_TRUE(factor.Factorize(A));
  single.Assign(factor.supernodal_view());
  single.Solve(b, x);
  EXPECT_LT((4.0 * x - first).norm(), 1e-5 * first.norm());
  EXPECT_LT((A * x - b).norm(), 1e-5 * b.norm());
  Eigen::VectorXd wrong(A.rows() + 1);
  EXPECT_DEATH(single.Solve(wrong, x), "size mismatch");
  EXPECT_DEATH(single.Solve(b, wrong), "size mismatch");
}

// the 2660-node liver breathing from rest (diaphragm prescribed, inferior tip fixed): the free
// motion with the float preconditioner against the double one, step by step from the same state
TEST(SinglePrecisionFactorTest, FemFreeMotionMatchesTheDoublePreconditioner) {
  TetMesh mesh = ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_2660.msh");
  FemBoundary boundary;
  const double z_min = mesh.X.row(2).minCoeff(), z_max = mesh.X.row(2).maxCoeff();
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (mesh.X(2, i) > z_max - 0.15 * (z_max - z_min)) boundary.prescribed_nodes.push_back(i);
    else if (mesh.X(2, i) < z_min + 0.05 * (z_max - z_min)) boundary.fixed_nodes.push_back(i);
  }
  FemConfig config;
  config.rayleigh_mass = 0.1;
  config.rayleigh_stiffness = 0.01;
  config.gravity.setZero();
  FemConfig double_config = config;
  double_config.single_precision_preconditioner = false;
  const FemModel model(mesh, config, boundary), double_model(mesh, double_config, boundary);
  FemSolver single(model), reference(double_model);
  FemState state(model), double_state(double_model);
  int single_iterations = 0, double_iterations = 0, largest_gap = 0;
  double largest_difference = 0.0;
  const int steps = 60;
  for (int step = 0; step < steps; ++step) {
    const double t = state.time + config.time_step;
    const double phase = std::pow(std::cos(M_PI * t / 4.0), 2);
    const Eigen::Vector3d offset(0.0, -0.004 * (1 - phase), -0.012 * (1 - phase));
    for (size_t k = 0; k < model.get_prescribed_nodes().size(); ++k)
      state.prescribed_positions.col(k) =
          model.get_rest_positions().col(model.get_prescribed_nodes()[k]) + offset;
    double_state = state;  // the same state: compare one solve
    const FemStepStats s = single.BeginStep(state);
    const FemStepStats d = reference.BeginStep(double_state);
    EXPECT_LE(s.relative_residual, config.cg_relative_tolerance) << step;
    single_iterations += s.cg_iterations;
    double_iterations += d.cg_iterations;
    largest_gap = std::max(largest_gap, std::abs(s.cg_iterations - d.cg_iterations));
    // both converged to the tolerance on the same operator: they differ by about the tolerance
    const double difference = (state.dv_free - double_state.dv_free).norm() / double_state.dv_free.norm();
    largest_difference = std::max(largest_difference, difference);
    single.CommitStep(state);
    reference.CommitStep(double_state);
  }
  std::printf("float vs double preconditioner over %d steps: PCG iterations %d vs %d (largest "
              "gap in a step %d), largest relative dv difference %.2e\n",
              steps, single_iterations, double_iterations, largest_gap, largest_difference);
  EXPECT_LE(largest_gap, 1);
  EXPECT_LE(std::abs(single_iterations - double_iterations), steps / 10);
  EXPECT_LT(largest_difference, 20.0 * config.cg_relative_tolerance);
}

}  // namespace
}  // namespace nsim
