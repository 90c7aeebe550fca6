#pragma once
// RAII wrapper of a CHOLMOD supernodal Cholesky factor (SuiteSparse 5.x, OpenBLAS) of a
// symmetric positive-definite matrix with a fixed sparsity pattern: symbolic analysis once
// (METIS/AMD ordering, supernodes), numeric factorization whenever the values change, and solves
// with any number of right-hand sides at once.

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
  /// Up to this many right-hand sides, Solve uses supernodal_solve.h (Eigen's vector kernels
  /// per column and supernode, the forward solve of a sparse column restricted to its path);
  /// more go to CHOLMOD's BLAS-3 supernodal solve. Measured on one core, 2660-node liver
  /// (fem_bench SolveColumns, SolveNodeColumns), this solve against CHOLMOD's: 1 column 0.7
  /// against 0.8-1.1 ms; the 3 columns of one node 1.1 against 3.1 ms, 6 (two nodes) 2.3
  /// against 4.2, 12 4.1 against 5.4; 12 dense columns 6.0 against 5.4.
  static constexpr int kMaxColumnsForSupernodalSolve = 8;

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
  /// alias B. k <= kMaxColumnsForSupernodalSolve: supernodal_solve.h (no allocation once its
  /// workspace has grown to k columns); more: cholmod_solve2 (its workspaces reused between
  /// calls with the same k). Not thread-safe on one object: one factor per thread.
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
