#include "common/fem/cholmod_factor.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

namespace nsim {
namespace {

constexpr double kSolveTol = 1e-12;  // relative residual of a direct solve, well-conditioned A

// random sparse SPD matrix: a graph Laplacian plus a positive diagonal, both triangles stored
Eigen::SparseMatrix<double> RandomSpd(int n, double shift, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::uniform_real_distribution<double> weight(0.1, 1.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) entries.emplace_back(i, i, shift);
  for (int k = 0; k < 4 * n; ++k) {
    const int i = pick(rng), j = pick(rng);
    if (i == j) continue;
    const double w = weight(rng);
    entries.emplace_back(i, i, w);
    entries.emplace_back(j, j, w);
    entries.emplace_back(i, j, -w);
    entries.emplace_back(j, i, -w);
  }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

TEST(CholmodFactorTest, SolvesSingleAndMultipleRightHandSides) {
  const Eigen::SparseMatrix<double> A = RandomSpd(400, 0.5, 1);
  CholmodFactor factor;
  factor.Analyze(A);
  ASSERT_TRUE(factor.Factorize(A));
  EXPECT_GT(factor.get_factor_nnz(), 400);
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(400, 7);
  Eigen::MatrixXd X(400, 7);
  factor.Solve(B, X);
  EXPECT_LT((A * X - B).norm(), kSolveTol * B.norm());
  // same result column by column, and as an Eigen dense LLT
  Eigen::VectorXd x(400);
  factor.Solve(B.col(3), x);
  EXPECT_LT((x - X.col(3)).norm(), kSolveTol * x.norm());
  const Eigen::MatrixXd X_ref = Eigen::MatrixXd(A).llt().solve(B);
  EXPECT_LT((X - X_ref).norm(), 1e-10 * X_ref.norm());
}

TEST(CholmodFactorTest, RefactorizesNewValuesAndDetectsIndefinite) {
  Eigen::SparseMatrix<double> A = RandomSpd(200, 1.0, 2);
  CholmodFactor factor;
  factor.Analyze(A);
  ASSERT_TRUE(factor.Factorize(A));
  // new values, same pattern
  for (int k = 0; k < A.nonZeros(); ++k) A.valuePtr()[k] *= 3.0;
  ASSERT_TRUE(factor.Factorize(A));
  const Eigen::VectorXd b = Eigen::VectorXd::Random(200);
  Eigen::VectorXd x(200);
  factor.Solve(b, x);
  EXPECT_LT((A * x - b).norm(), kSolveTol * b.norm());
  // negate: not positive definite
  for (int k = 0; k < A.nonZeros(); ++k) A.valuePtr()[k] *= -1.0;
  EXPECT_FALSE(factor.Factorize(A));
  EXPECT_FALSE(factor.is_factorized());
}

// a copy solves bit-identically to the original, and refactorizing the copy with other values
// leaves the original as it was
TEST(CholmodFactorTest, CopyIsIndependentAndExact) {
  Eigen::SparseMatrix<double> A = RandomSpd(300, 0.5, 3);
  CholmodFactor original;
  original.Analyze(A);
  ASSERT_TRUE(original.Factorize(A));
  CholmodFactor copy;
  copy.CopyFrom(original);
  ASSERT_TRUE(copy.is_factorized());
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(300, 4);
  Eigen::MatrixXd X(300, 4), X_copy(300, 4);
  original.Solve(B, X);
  copy.Solve(B, X_copy);
  EXPECT_EQ((X - X_copy).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::SparseMatrix<double> A_original = A;
  for (int k = 0; k < A.nonZeros(); ++k) A.valuePtr()[k] *= 2.0;
  ASSERT_TRUE(copy.Factorize(A));
  copy.Solve(B, X_copy);
  EXPECT_LT((A * X_copy - B).norm(), kSolveTol * B.norm());
  Eigen::MatrixXd X_again(300, 4);
  original.Solve(B, X_again);
  EXPECT_EQ((X - X_again).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((A_original * X_again - B).norm(), kSolveTol * B.norm());
}

}  // namespace
}  // namespace nsim
