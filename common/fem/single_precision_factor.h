#pragma once
// A single-precision copy of a supernodal Cholesky factor L L' = P A P' (CHOLMOD's supernodal
// layout, SuiteSparse 5.x: Debian 12's CHOLMOD has no single precision of its own) and its
// solve x = P' L'^-1 L^-1 P b.
//
// What it is for: the preconditioner of the FEM solver's conjugate gradient. A supernodal
// triangular solve with one right-hand side is bound by reading L (memory bound: on the
// 2660-node liver L has 1.53 M entries, 12 MB in double, read twice per solve), so halving the
// bytes of L roughly halves its cost. Its accuracy, a relative error of about cond(A) x 6e-8
// in the preconditioned vector, is far below the error of the preconditioner itself (a factor
// of an earlier A, warped by nodal rotations), and the conjugate gradient is still iterated to
// its tolerance on the exact double-precision operator: the free motion's accuracy does not
// depend on it (fem_solver_test, single_precision_factor_test). Everything that needs A^-1
// itself (constraint compliance: FemInverse) keeps the double-precision factor.
//
// Deterministic: Eigen's fixed-order kernels, no threads, the same bits on every run of one
// build. The kernels (supernodal_solve.h, shared with CholmodFactor's solves of a few columns)
// are Eigen's triangular solve and matrix-vector product on each supernode's block; OpenBLAS's
// strsv / sgemv measured slower here (the call overhead of the many small supernodes), and so
// did hand-written column loops.

#include <Eigen/Core>
#include <vector>

#include "common/fem/cholmod_factor.h"

namespace nsim {

class SinglePrecisionFactor {
 public:
  /// Copies `view` (pattern and values, the values rounded to float).
  void Assign(const SupernodalFactorView& view);
  bool empty() const { return n_ == 0; }
  int rows() const { return n_; }

  /// x = A^-1 b with the float factor (x and b of size n, may not alias). Not thread-safe on
  /// one object (scratch vectors).
  void Solve(const Eigen::Ref<const Eigen::VectorXd>& b, Eigen::Ref<Eigen::VectorXd> x);

 private:
  int n_ = 0;
  std::vector<int> super_, pi_, px_, s_, perm_;
  std::vector<float> values_;
  Eigen::VectorXf y_;         // the permuted vector
  Eigen::VectorXf gathered_;  // a supernode's rows below its columns
};

}  // namespace nsim
