#include "common/control/regularized_inverse.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

// capacity-bounded types: dynamic sizes on the stack, no heap allocation
using DofMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxControlDof, kMaxControlDof>;
using DofByRows =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxControlDof, kMaxObjectiveRows>;
using RowsByDof =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxObjectiveRows, kMaxControlDof>;

void CheckJacobian(const Eigen::MatrixXd& J, const char* what) {
  if (J.cols() < 1 || J.rows() < 1 || J.cols() > kMaxControlDof || J.rows() > kMaxObjectiveRows) {
    throw InputError(Str(what, ": expected a Jacobian of 1..", kMaxObjectiveRows, " rows and 1..",
                         kMaxControlDof, " columns, got ", J.rows(), " x ", J.cols()));
  }
  if (!J.allFinite()) throw InputError(Str(what, ": the Jacobian has a non-finite entry"));
}

}  // namespace

void CalcTikhonovPseudoInverse(const Eigen::MatrixXd& J, double r, Eigen::MatrixXd* J_r_plus,
                               TikhonovForm form) {
  CheckJacobian(J, "Tikhonov pseudo-inverse");
  if (!(r > 0.0) || !std::isfinite(r)) {
    throw InputError(Str("Tikhonov regularization r must be > 0, got ", r));
  }
  const int n = static_cast<int>(J.cols());
  const int m = static_cast<int>(J.rows());
  // J = U_J S V_J^T, hence J^T J = V_J S^2 V_J^T: U = V = V_J and d_kk = s_k^2 (thin: the
  // null space of J, where J^T has no component, drops out exactly)
  const RowsByDof Jc = J;
  Eigen::JacobiSVD<RowsByDof> svd(Jc, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const int k_max = static_cast<int>(svd.singularValues().size());
  // J_r^+ = V diag(g) V^T J^T = V_J diag(g_k s_k) U_J^T
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxControlDof, 1> gain(k_max);
  for (int k = 0; k < k_max; ++k) {
    const double s = svd.singularValues()[k];
    const double d = s * s;
    const double delta = d > r ? d : r;  // eq. 3.8
    gain[k] = form == TikhonovForm::kClampedSpectrum ? s / delta : s / (d + r * delta);
  }
  DofByRows SUt(k_max, m);
  SUt.noalias() = gain.asDiagonal() * svd.matrixU().transpose();
  J_r_plus->resize(n, m);
  J_r_plus->noalias() = svd.matrixV() * SUt;
}

double CalcTikhonovNormBound(double r, TikhonovForm form) {
  if (form == TikhonovForm::kClampedSpectrum) return 1.0 / std::sqrt(r);
  return std::max(1.0 / (2.0 * r), 1.0 / ((1.0 + r) * std::sqrt(r)));
}

void CalcDampedLeastSquaresInverse(const Eigen::MatrixXd& J, double lambda,
                                   Eigen::MatrixXd* J_dls) {
  CheckJacobian(J, "damped least squares inverse");
  if (!(lambda > 0.0) || !std::isfinite(lambda)) {
    throw InputError(Str("damped least squares lambda must be > 0, got ", lambda));
  }
  const int n = static_cast<int>(J.cols());
  DofMatrix G(n, n);
  G.noalias() = J.transpose() * J;
  G.diagonal().array() += lambda * lambda;
  Eigen::LLT<DofMatrix> llt(G);
  DofByRows Jt = J.transpose();
  llt.solveInPlace(Jt);
  *J_dls = Jt;
}

}  // namespace nsim
