// WorkerGate (common/fem/worker_gate.h): a bound thread waits at its safe points while the gate
// is closed, other threads never do, and the four interposed BLAS / LAPACK routines both pass
// the gate and compute what the BLAS library computes (checked against Eigen's products and
// factorization). Waits are bounded: every wait for a thread polls with a deadline.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <atomic>
#include <chrono>
#include <functional>
#include <thread>

#include "common/fem/cholmod_factor.h"
#include "common/fem/worker_gate.h"

extern "C" {
void dgemm_(char* transa, char* transb, int* m, int* n, int* k, double* alpha, double* a, int* lda,
            double* b, int* ldb, double* beta, double* c, int* ldc);
void dsyrk_(char* uplo, char* trans, int* n, int* k, double* alpha, double* a, int* lda,
            double* beta, double* c, int* ldc);
void dtrsm_(char* side, char* uplo, char* transa, char* diag, int* m, int* n, double* alpha,
            double* a, int* lda, double* b, int* ldb);
void dpotrf_(char* uplo, int* n, double* a, int* lda, int* info);
}

namespace nsim {
namespace {

using std::chrono::milliseconds;

// polls `done` every millisecond for at most 10 s
bool Eventually(const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(milliseconds(1));
  }
  return true;
}

// runs `work` on a thread bound to `gate` with the gate closed: the work must not have ended
// 100 ms after the thread reached a safe point, and must end once the gate opens
void ExpectHeldUntilOpen(WorkerGate& gate, const std::function<void()>& work) {
  gate.Close();
  const long waits_before = gate.waits();
  std::atomic<bool> ended{false};
  std::thread thread([&] {
    gate.BindToThisThread();
    work();
    WorkerGate::UnbindThisThread();
    ended = true;
  });
  ASSERT_TRUE(Eventually([&] { return gate.waits() > waits_before; }))
      << "the bound thread never waited at the closed gate";
  std::this_thread::sleep_for(milliseconds(100));
  EXPECT_FALSE(ended.load()) << "the bound thread went past the closed gate";
  gate.Open();
  EXPECT_TRUE(Eventually([&] { return ended.load(); }));
  thread.join();
}

TEST(WorkerGateTest, TheBoundThreadWaitsAtASafePointWhileClosed) {
  WorkerGate gate;
  EXPECT_FALSE(gate.closed());
  int passed = 0;
  ExpectHeldUntilOpen(gate, [&] {
    PassWorkerGate();
    ++passed;
  });
  EXPECT_EQ(passed, 1);
  EXPECT_EQ(gate.waits(), 1);
  EXPECT_FALSE(gate.closed());
}

TEST(WorkerGateTest, OpenGatesAndUnboundThreadsPassWithoutWaiting) {
  WorkerGate gate;
  gate.Close();
  PassWorkerGate();  // this thread is not bound: passes
  gate.Open();
  std::thread thread([&] {
    gate.BindToThisThread();
    for (int i = 0; i < 1000; ++i) PassWorkerGate();
    WorkerGate::UnbindThisThread();
  });
  thread.join();
  EXPECT_EQ(gate.waits(), 0);
}

// each interposed routine waits at the gate, then computes the BLAS library's result
TEST(WorkerGateTest, TheInterposedDgemmWaitsThenMultiplies) {
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(7, 5), b = Eigen::MatrixXd::Random(5, 6);
  Eigen::MatrixXd c = Eigen::MatrixXd::Random(7, 6);
  const Eigen::MatrixXd expected = 2.0 * a * b + 0.5 * c;
  WorkerGate gate;
  ExpectHeldUntilOpen(gate, [&] {
    char no = 'N';
    int m = 7, n = 6, k = 5, lda = 7, ldb = 5, ldc = 7;
    double alpha = 2.0, beta = 0.5;
    Eigen::MatrixXd a_copy = a, b_copy = b;
    dgemm_(&no, &no, &m, &n, &k, &alpha, a_copy.data(), &lda, b_copy.data(), &ldb, &beta,
           c.data(), &ldc);
  });
  EXPECT_LT((c - expected).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(WorkerGateTest, TheInterposedDsyrkWaitsThenUpdates) {
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(6, 4);
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(6, 6);
  const Eigen::MatrixXd expected = -1.0 * a * a.transpose();
  WorkerGate gate;
  ExpectHeldUntilOpen(gate, [&] {
    char lower = 'L', no = 'N';
    int n = 6, k = 4, lda = 6, ldc = 6;
    double alpha = -1.0, beta = 0.0;
    Eigen::MatrixXd a_copy = a;
    dsyrk_(&lower, &no, &n, &k, &alpha, a_copy.data(), &lda, &beta, c.data(), &ldc);
  });
  const Eigen::MatrixXd lower_c = c.triangularView<Eigen::Lower>();
  const Eigen::MatrixXd lower_expected = expected.triangularView<Eigen::Lower>();
  EXPECT_LT((lower_c - lower_expected).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(WorkerGateTest, TheInterposedDpotrfAndDtrsmWaitThenFactorAndSolve) {
  const Eigen::MatrixXd r = Eigen::MatrixXd::Random(5, 5);
  const Eigen::MatrixXd spd = r * r.transpose() + 5.0 * Eigen::MatrixXd::Identity(5, 5);
  const Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(5, 3);
  Eigen::MatrixXd factor = spd, solution = rhs;
  int info = -1;
  WorkerGate gate;
  ExpectHeldUntilOpen(gate, [&] {
    char lower = 'L', left = 'L', no = 'N', non_unit = 'N';
    int n = 5, lda = 5, nrhs = 3;
    double one = 1.0;
    dpotrf_(&lower, &n, factor.data(), &lda, &info);
    // L y = rhs
    dtrsm_(&left, &lower, &no, &non_unit, &n, &nrhs, &one, factor.data(), &lda, solution.data(),
           &lda);
  });
  ASSERT_EQ(info, 0);
  const Eigen::MatrixXd l = factor.triangularView<Eigen::Lower>();
  const Eigen::MatrixXd l_expected = spd.llt().matrixL();
  EXPECT_LT((l - l_expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((l * solution - rhs).cwiseAbs().maxCoeff(), 1e-12);
  // dpotrf_ waited at the gate before dtrsm_ was reached: one wait in all (the gate opened)
  EXPECT_EQ(gate.waits(), 1);
}

// CHOLMOD's supernodal factorization reaches the gate through the interposed routines (the
// dynamic linker binds its BLAS calls to this executable's definitions): a factorization on a
// bound thread waits while the gate is closed, then gives the factor of the matrix
TEST(WorkerGateTest, CholmodsSupernodalFactorizationWaitsAtItsBlasCalls) {
  // the 7-point Laplacian of a 12^3 grid plus the identity: supernodes large enough for BLAS
  constexpr int kSide = 12, kN = kSide * kSide * kSide;
  std::vector<Eigen::Triplet<double>> entries;
  const auto index = [](int i, int j, int k) { return (k * kSide + j) * kSide + i; };
  for (int k = 0; k < kSide; ++k)
    for (int j = 0; j < kSide; ++j)
      for (int i = 0; i < kSide; ++i) {
        const int row = index(i, j, k);
        entries.emplace_back(row, row, 7.0);
        if (i + 1 < kSide) entries.emplace_back(row, index(i + 1, j, k), -1.0);
        if (j + 1 < kSide) entries.emplace_back(row, index(i, j + 1, k), -1.0);
        if (k + 1 < kSide) entries.emplace_back(row, index(i, j, k + 1), -1.0);
      }
  Eigen::SparseMatrix<double> upper(kN, kN);  // CHOLMOD reads the upper triangle
  upper.setFromTriplets(entries.begin(), entries.end());
  upper.makeCompressed();
  CholmodFactor factor;
  factor.Analyze(upper);
  bool ok = false;
  WorkerGate gate;
  ExpectHeldUntilOpen(gate, [&] { ok = factor.Factorize(upper); });
  ASSERT_TRUE(ok);
  const Eigen::SparseMatrix<double> full =
      upper.selfadjointView<Eigen::Upper>() * Eigen::SparseMatrix<double>(
                                                  Eigen::VectorXd::Ones(kN).asDiagonal());
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(kN, 2);
  Eigen::MatrixXd x(kN, 2);
  factor.Solve(b, x);
  EXPECT_LT((full * x - b).cwiseAbs().maxCoeff(), 1e-10);
}

}  // namespace
}  // namespace nsim
