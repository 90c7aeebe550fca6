#pragma once
// RAII wrapper of a CHOLMOD supernodal Cholesky factor (SuiteSparse 5.x, OpenBLAS) of a
// symmetric positive-definite matrix with a fixed sparsity pattern: symbolic analysis once
// (METIS/AMD ordering, supernodes), numeric factorization whenever the values change, and solves
// with any number of right-hand sides at once (BLAS-3 in the supernodal solve).

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

#include "common/fem/single_precision_factor.h"

namespace nsim {

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
  /// alias B. Reuses CHOLMOD workspaces between calls with the same k (no allocation then).
  /// Not thread-safe on one object: one factor per thread.
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
