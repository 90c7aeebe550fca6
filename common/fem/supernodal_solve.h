#pragma once
// The two triangular solves of a supernodal Cholesky factor, L L' y = b in the factor's
// (permuted) order, on CHOLMOD's supernodal layout (SupernodalFactorView), with Eigen's
// fixed-order kernels on each supernode's block: the triangular solve of its diagonal block,
// then the product with the rows below it, gathered and scattered through its row indices.
//
// Why not cholmod_solve2: its supernodal solve calls BLAS per supernode (dtrsv / dgemv for one
// right-hand side, dtrsm / dgemm for several), and on the 2660-node liver, most of whose
// supernodes are a few columns wide, the call overhead of dtrsm / dgemm dominates: measured on
// one core (fem_bench SolveColumns), 3 right-hand sides took 4x the time of one, more than 3
// solves of one. Eigen's matrix kernels (blocked, packed) fare no better on such small blocks;
// its vector kernels are fast (single_precision_factor.h), so each column gets those, and L is
// read from memory once for all columns.
// Deterministic: no threads, a fixed order of operations for a given factor and k.

#include <Eigen/Core>

#include "common/fem/cholmod_factor.h"

namespace nsim {

/// Y <- (L L')^-1 Y in place, Y of n rows (the factor's permuted order) and any number of
/// columns (a vector or a column-major matrix, unit inner stride); L's values `x` (float or
/// double) in the layout of `view` (its x and perm are not read). `gathered` is scratch,
/// grown as needed. The columns are solved one by one within each supernode (a triangular
/// solve and a matrix-vector product per column, Eigen's vector kernels), so that a supernode's
/// block is read from memory once and from cache for the other columns.
template <class Scalar, class Rhs>
void SupernodalSolveInPlace(const SupernodalFactorView& view, const Scalar* x,
                            Eigen::MatrixBase<Rhs>& Y,
                            Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& gathered) {
  using Block = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  using BlockMap = Eigen::Map<const Block, 0, Eigen::OuterStride<>>;
  // supernode j: its first column k1, its width, the number of rows below its columns, its
  // nsrow x nscol block of L (column-major, its own columns' rows first), the rows below
  struct Supernode {
    int k1, nscol, below;
    BlockMap L;
    const int* rows;
  };
  const auto supernode = [&](int j) {
    const int k1 = view.super[j], nscol = view.super[j + 1] - k1;
    const int psi = view.pi[j], nsrow = view.pi[j + 1] - psi;
    if (gathered.size() < nsrow - nscol) gathered.resize(nsrow - nscol);
    return Supernode{k1, nscol, nsrow - nscol,
                     BlockMap(x + view.px[j], nsrow, nscol, Eigen::OuterStride<>(nsrow)),
                     view.s + psi + nscol};
  };
  const Eigen::Index k = Y.cols();
  // L y = b, supernode by supernode
  for (int j = 0; j < view.nsuper; ++j) {
    const Supernode sn = supernode(j);
    for (Eigen::Index c = 0; c < k; ++c) {
      auto y = Y.col(c);
      auto y1 = y.segment(sn.k1, sn.nscol);
      // a sparse right-hand side (a unit column: a constraint point's compliance) is nonzero
      // only on the supernodes of its elimination-tree path; the others are skipped (exact)
      if (y1.isZero(0)) continue;
      sn.L.topRows(sn.nscol).template triangularView<Eigen::Lower>().solveInPlace(y1);
      if (sn.below == 0) continue;
      gathered.head(sn.below).noalias() = sn.L.bottomRows(sn.below) * y1;
      for (int i = 0; i < sn.below; ++i) y[sn.rows[i]] -= gathered[i];
    }
  }
  // L' z = y, backwards: the rows below a supernode are final when it is reached
  for (int j = view.nsuper - 1; j >= 0; --j) {
    const Supernode sn = supernode(j);
    for (Eigen::Index c = 0; c < k; ++c) {
      auto y = Y.col(c);
      auto y1 = y.segment(sn.k1, sn.nscol);
      if (sn.below > 0) {
        for (int i = 0; i < sn.below; ++i) gathered[i] = y[sn.rows[i]];
        y1.noalias() -= sn.L.bottomRows(sn.below).transpose() * gathered.head(sn.below);
      }
      sn.L.topRows(sn.nscol).template triangularView<Eigen::Lower>().transpose().solveInPlace(y1);
    }
  }
}

}  // namespace nsim
