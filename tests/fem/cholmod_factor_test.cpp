#include "common/fem/cholmod_factor.h"

#include <gtest/gtest.h>

#include <omp.h>

#include <Eigen/Dense>
#include <filesystem>
#include <random>
#include <thread>

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

// Solve (supernodal_solve.h) agrees with a dense LLT for dense, unit (a constraint point's
// compliance: the forward solve skips the supernodes off the column's path) and zero columns,
// and a column's solution is the same to the bit whatever is solved with it and wherever it
// stands (what lets compliance columns be solved ahead of the step that needs them without
// changing any result)
TEST(CholmodFactorTest, EveryNumberOfColumnsSolvesLikeADenseFactor) {
  const int n = 601;  // not a multiple of a packet
  const Eigen::SparseMatrix<double> A = RandomSpd(n, 0.2, 7);
  CholmodFactor factor;
  factor.Analyze(A);
  ASSERT_TRUE(factor.Factorize(A));
  const Eigen::MatrixXd A_dense(A);
  const Eigen::LLT<Eigen::MatrixXd> dense(A_dense);
  for (int k : {1, 2, 3, 8, 13, 40}) {
    for (int kind = 0; kind < 3; ++kind) {  // dense, unit, zero first column + dense
      Eigen::MatrixXd B = Eigen::MatrixXd::Random(n, k);
      if (kind == 1) {
        B.setZero();
        for (int c = 0; c < k; ++c) B((97 * c + 13) % n, c) = 1.0;
      }
      if (kind == 2) B.col(0).setZero();
      Eigen::MatrixXd X(n, k);
      factor.Solve(B, X);
      const Eigen::MatrixXd X_ref = dense.solve(B);
      SCOPED_TRACE(testing::Message() << k << " columns, kind " << kind);
      EXPECT_LE((A * X - B).norm(), kSolveTol * B.norm());
      EXPECT_LE((X - X_ref).norm(), 1e-10 * X_ref.norm());
      if (kind == 2) {
        EXPECT_EQ(X.col(0).squaredNorm(), 0.0);
      }
      // each column alone, and the columns in reverse order: the same bits
      Eigen::MatrixXd reversed(n, k), X_reversed(n, k);
      for (int c = 0; c < k; ++c) reversed.col(c) = B.col(k - 1 - c);
      factor.Solve(reversed, X_reversed);
      for (int c = 0; c < k; ++c) {
        Eigen::VectorXd alone(n);
        factor.Solve(B.col(c), alone);
        EXPECT_TRUE(alone == X.col(c)) << "column " << c << " alone";
        EXPECT_TRUE(X_reversed.col(k - 1 - c) == X.col(c)) << "column " << c << " reversed";
      }
    }
  }
}

int CountThreadsOfThisProcess() {
  int count = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator("/proc/self/task"))
    ++count;
  return count;
}

// CHOLMOD's factorization asks OpenMP for 4 threads whatever OMP_NUM_THREADS says; the factor
// keeps it on the calling thread (cholmod_factor.cpp, SerialOpenMp). A thread that opens an
// OpenMP team keeps its pool's threads alive afterwards, so a team of more than one would show
// as new threads of the process. Run on a fresh thread, so no pool exists before.
TEST(CholmodFactorTest, FactorizesOnTheCallingThreadAlone) {
  const Eigen::SparseMatrix<double> A = RandomSpd(3000, 0.5, 5);  // fill-in: supernodes > 1024
  int before = 0, after = 0, levels_before = 0, levels_after = 0;
  double residual = 1.0;
  std::thread caller([&] {
    levels_before = omp_get_max_active_levels();
    before = CountThreadsOfThisProcess();
    CholmodFactor factor;
    factor.Analyze(A);
    if (!factor.Factorize(A)) return;
    after = CountThreadsOfThisProcess();
    levels_after = omp_get_max_active_levels();
    const Eigen::VectorXd b = Eigen::VectorXd::Ones(A.rows());
    Eigen::VectorXd x(A.rows());
    factor.Solve(b, x);
    residual = (A * x - b).norm() / b.norm();
  });
  caller.join();
  ASSERT_GT(before, 0);
  EXPECT_EQ(after, before) << "CHOLMOD's factorization started OpenMP threads";
  EXPECT_EQ(levels_after, levels_before) << "the thread's max-active-levels was not restored";
  EXPECT_LT(residual, kSolveTol);
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
