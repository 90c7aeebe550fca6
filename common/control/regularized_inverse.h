#pragma once
// Regularized inverses of the simulation Jacobian J (thesis eq. 3.7-3.8, used again for the
// joint-space Jacobian in appendix A): the thesis's Tikhonov form and, for comparison, the usual
// damped least squares.
//
// Shapes: J is m x n with m objective rows (e = J dchi: 4, 5 or 6 in the three insertion
// phases) and n controlled DoF (6 Cartesian or 7 joints); the inverse is n x m. (The thesis
// writes J_6(1) in R^{6x4}, i.e. DoF x rows; here rows are objectives, columns DoF.)
//
// Reading of eq. 3.7. Printed: J_6r^+ = (J^T J + r U Delta V^T) J^T, with J^T J = U D V^T (SVD)
// and, eq. 3.8, Delta_kk = d_kk if d_kk > r, else r; the matrix is named Delta_{sigma(J^T J) < r}.
// As printed, the expression has no inverse, so it scales like J^3 and is not an inverse of J at
// all (its product with J is not near the identity for any J), and r multiplies an entry that
// is itself r or d_kk, so r cannot carry one unit. Two readings repair it:
//  - kClampedSpectrum (default): the subscript says the regularization acts on the part of the
//    spectrum below r. J^T J is symmetric positive semi-definite, so U = V and D holds its
//    eigenvalues; adding to J^T J the term U diag(max(0, r - d_kk)) V^T raises only those
//    eigenvalues below r up to r, and the sum is exactly U Delta V^T with Delta of eq. 3.8. So
//      J_r^+ = (U Delta V^T)^-1 J^T = V Delta^-1 U^T J^T.
//    Units are consistent (r in the units of J^T J), directions with d_kk > r get the exact
//    Moore-Penrose inverse (no bias where J is well conditioned, the point of a selective
//    Tikhonov term), and every gain is bounded: a singular value s of J gives s / max(s^2, r)
//    <= 1 / sqrt(r), so ||J_r^+||_2 <= 1 / sqrt(r).
//  - kLiteralAdditive: the printed sum with the missing inverse restored,
//      J_r^+ = (J^T J + r U Delta V^T)^-1 J^T = V diag(1 / (d_kk + r Delta_kk)) U^T J^T.
//    Eigenvalues above r are scaled by (1 + r) (J_r^+ = J^+ / (1 + r) when all d_kk > r), those
//    below get the Tikhonov damping r^2: s / (s^2 + r^2) <= 1 / (2 r). The bound for r < 1/4 is
//    ||J_r^+|| <= 1 / (2 r); in general max(1 / (2 r), 1 / ((1 + r) sqrt(r))). It only makes
//    dimensional sense for a J normalized to be unitless.
// The default is kClampedSpectrum, the reading that agrees with the subscript, eq. 3.8, the
// units and the stated purpose ("prevent the ill conditioning").
//
// Computation: from the SVD of J itself, J = U_J S V_J^T, so J^T J = V_J S^2 V_J^T, i.e. the
// thesis's U = V = V_J and d_kk = s_k^2; J_r^+ = V_J diag(s_k / f(s_k^2)) U_J^T. This is the same
// matrix as eq. 3.7 but never forms J^T J, which would square the condition number (d_kk near r
// = 1e-6 would carry absolute errors eps d_max), and it needs no care for the sign freedom of a
// general SVD of J^T J on its null space (U != V there would make U Delta V^T non-symmetric). The
// null space of J gets no gain, exactly: J^T has no component there.

#include <Eigen/Core>

namespace nsim {

/// Largest number of controlled DoF (columns of J) the inverses accept.
inline constexpr int kMaxControlDof = 12;
/// Largest number of objective rows (rows of J) the inverses accept.
inline constexpr int kMaxObjectiveRows = 32;

/// Which reading of eq. 3.7 (see the file comment).
enum class TikhonovForm {
  kClampedSpectrum,  ///< V diag(1 / max(d, r)) U^T J^T (default)
  kLiteralAdditive,  ///< (J^T J + r U Delta V^T)^-1 J^T
};

/// Thesis eq. 3.7-3.8: the Tikhonov-regularized pseudo-inverse J_r^+ (n x m) of J (m x n,
/// n <= kMaxControlDof, m <= kMaxObjectiveRows), threshold r > 0 in the units of J^T J.
/// Throws InputError on a non-finite J, r <= 0 or oversize J. No heap allocation once
/// *J_r_plus has the right size.
void CalcTikhonovPseudoInverse(const Eigen::MatrixXd& J, double r, Eigen::MatrixXd* J_r_plus,
                               TikhonovForm form = TikhonovForm::kClampedSpectrum);

/// Upper bound of ||J_r^+||_2 over all J for threshold r (see the file comment):
/// 1 / sqrt(r) for kClampedSpectrum, max(1 / (2 r), 1 / ((1 + r) sqrt(r))) for kLiteralAdditive.
double CalcTikhonovNormBound(double r, TikhonovForm form);

/// Damped least squares (Levenberg-Marquardt, Wampler / Nakamura): J^T (J J^T + lambda^2 I)^-1,
/// computed as (J^T J + lambda^2 I)^-1 J^T (the same matrix). lambda > 0 in the units of J.
/// ||result|| <= 1 / (2 lambda). Same size limits and errors as CalcTikhonovPseudoInverse.
void CalcDampedLeastSquaresInverse(const Eigen::MatrixXd& J, double lambda, Eigen::MatrixXd* J_dls);

}  // namespace nsim
