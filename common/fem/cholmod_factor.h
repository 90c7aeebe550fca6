#pragma once
// RAII wrapper of a CHOLMOD supernodal Cholesky factor (SuiteSparse 5.x, OpenBLAS) of a
// symmetric positive-definite matrix with a fixed sparsity pattern: symbolic analysis once
// (METIS/AMD ordering, supernodes), numeric factorization whenever the values change, and solves
// with any number of right-hand sides at once (supernodal_solve.h on the factor's arrays).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

namespace nsim {

/// The arrays of a supernodal LL' factor, as CHOLMOD stores them (int indices), borrowed.
struct SupernodalFactorView {
  int n = 0;                       ///< order of A
  int nsuper = 0;                  ///< number of supernodes
  const int* super = nullptr;      ///< [nsuper + 1] first column of each supernode
  const int* pi = nullptr;         ///< [nsuper + 1] start of each supernode's rows in s
  const int* px = nullptr;         ///< [nsuper + 1] start of each supernode's values in x
  const int* s = nullptr;          ///< row indices (the supernode's own columns first)
  const double* x = nullptr;       ///< values, column-major per supernode (nsrow x nscol)
  const int* perm = nullptr;       ///< [n] fill-reducing permutation: row k of P A P' is row perm[k] of A
};

class CholmodFactor {
 public:
  CholmodFactor();
  ~CholmodFactor();
  CholmodFactor(const CholmodFactor&) = delete;
  CholmodFactor& operator=(const CholmodFactor&) = delete;

  /// Symbolic analysis of the pattern of A (square, both triangles stored, compressed; only the
  /// upper triangle is read). Must precede Factorize; repeat only if the pattern changes.
  void Analyze(const Eigen::SparseMatrix<double>& A);

  /// Numeric factorization of A (same pattern as analysed). Returns false, leaving the factor
  /// unusable, when A is not positive definite.
  bool Factorize(const Eigen::SparseMatrix<double>& A);

  /// Makes this an exact copy of `other`'s analysis and numeric factor (cholmod_copy_factor: a
  /// memory copy, no factorization; solves then give bit-identical results). `other` must be
  /// analysed. Solve workspaces are not copied.
  void CopyFrom(const CholmodFactor& other);

  /// X = A^-1 B for B of size n x k (any k >= 1, column-major with unit inner stride). X may not
  /// alias B. By supernodal_solve.h, not cholmod_solve2: measured on one core, 2660-node liver
  /// (fem_bench SolveColumns, SolveNodeColumns), against CHOLMOD's: 1 column 0.7 against
  /// 0.8-1.1 ms; the 3 unit columns of one node 1.1 against 3.1 ms, of two nodes 2.3 against
  /// 4.2, of four 4.1 against 5.4; 12 dense columns 6.0 against 5.4 (CHOLMOD's BLAS-3 ahead
  /// there; no caller solves dense columns in bulk). Each column's solution is the same to the
  /// bit whatever is solved with it and wherever it stands in B. No allocation once the
  /// workspace has grown to k columns. Not thread-safe on one object: one factor per thread.
  void Solve(const Eigen::Ref<const Eigen::MatrixXd>& B, Eigen::Ref<Eigen::MatrixXd> X);

  /// The supernodal factor's arrays (valid until the next Analyze, Factorize or CopyFrom), to
  /// copy it in single precision (SinglePrecisionFactor::Assign). Requires a factorization.
  SupernodalFactorView supernodal_view() const;

  int rows() const;
  bool is_analyzed() const;
  bool is_factorized() const { return factorized_; }
  /// Number of stored entries of L (after the last factorization or analysis).
  double get_factor_nnz() const;
  /// Floating-point operations of the last numeric factorization.
  double get_factor_flops() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool factorized_ = false;
};

}  // namespace nsim
