#include "common/fem/corotational.h"

#include <Eigen/Dense>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

namespace {

// local stress of the linear material for a displacement gradient G (-): lambda tr(G) I + mu (G + G^T)
inline Eigen::Matrix3d LinearStress(const LameParameters& lame, const Eigen::Matrix3d& G) {
  Eigen::Matrix3d sigma = lame.mu * (G + G.transpose());
  sigma.diagonal().array() += lame.lambda * G.trace();
  return sigma;
}

}  // namespace

TetRestShape CalcTetRestShape(const Matrix34d& X) {
  Eigen::Matrix3d Dm;
  Dm.col(0) = X.col(1) - X.col(0);
  Dm.col(1) = X.col(2) - X.col(0);
  Dm.col(2) = X.col(3) - X.col(0);
  const double det = Dm.determinant();
  // scale-free degeneracy test: det relative to the cube of the longest edge
  const double edge = std::max({Dm.col(0).norm(), Dm.col(1).norm(), Dm.col(2).norm(),
                                (X.col(2) - X.col(1)).norm(), (X.col(3) - X.col(1)).norm(),
                                (X.col(3) - X.col(2)).norm()});
  if (!(det > 1e-12 * edge * edge * edge))
    throw InputError(Str("tetrahedron rest volume must be > 0, got ", det / 6.0, " m^3"));
  TetRestShape rest;
  rest.volume = det / 6.0;
  const Eigen::Matrix3d Dm_inv = Dm.inverse();
  // N_a for a = 1..3 are the barycentric coordinates: gradients are the rows of Dm^-1
  rest.grad_n.rightCols<3>() = Dm_inv.transpose();
  rest.grad_n.col(0) = -rest.grad_n.rightCols<3>().rowwise().sum();
  return rest;
}

Eigen::Matrix3d CalcDeformationGradient(const TetRestShape& rest, const Matrix34d& x) {
  return x * rest.grad_n.transpose();
}

Eigen::Matrix3d CalcPolarRotation(const Eigen::Matrix3d& F, bool* used_svd) {
  const double det = F.determinant();
  if (det > kPolarSvdThreshold) {
    if (used_svd) *used_svd = false;
    // Higham's Newton iteration X <- (g X + (g X)^-T) / 2 with determinant scaling g;
    // converges quadratically to the orthogonal polar factor, which is a rotation as det F > 0
    Eigen::Matrix3d X = F;
    double det_x = det;
    for (int it = 0; it < 30; ++it) {
      // X^-T = cofactor(X) / det X
      Eigen::Matrix3d cof;
      cof.col(0) = X.col(1).cross(X.col(2));
      cof.col(1) = X.col(2).cross(X.col(0));
      cof.col(2) = X.col(0).cross(X.col(1));
      if (it > 0) det_x = X.col(0).dot(cof.col(0));
      // |det(gX)| = 1; near-orthogonal iterates need no scaling (saves the cube root)
      const double g = std::abs(det_x - 1.0) < 1e-2 ? 1.0 : 1.0 / std::cbrt(det_x);
      Eigen::Matrix3d next = 0.5 * (g * X + cof / (g * det_x));
      const double change = (next - X).squaredNorm();
      X = next;
      // X = Q (I + E), E symmetric, becomes Q (I + E^2 / 2 + O(E^3)) in a step that changes
      // X by ||E||: after a step of norm below kPolarStepTolerance the iterate is within
      // about kPolarStepTolerance^2 / 2 of the polar factor (E^2 / 2 plus higher orders)
      if (change < kPolarStepTolerance * kPolarStepTolerance) break;
    }
    return X;
  }
  if (used_svd) *used_svd = true;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  // singular values are sorted decreasing: flip the last column to make both proper rotations
  if (U.determinant() < 0) U.col(2) = -U.col(2);
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  return U * V.transpose();
}

Matrix12d CalcCorotatedStiffness(const TetRestShape& rest, const LameParameters& lame,
                                 const Eigen::Matrix3d& R) {
  const Matrix34d r = R * rest.grad_n;  // rotated gradients
  const Eigen::Matrix4d gg = rest.grad_n.transpose() * rest.grad_n;
  Matrix12d K;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {
      Eigen::Matrix3d block = lame.lambda * r.col(a) * r.col(b).transpose() +
                              lame.mu * r.col(b) * r.col(a).transpose();
      block.diagonal().array() += lame.mu * gg(a, b);
      K.block<3, 3>(3 * a, 3 * b) = rest.volume * block;
    }
  }
  return K;
}

Matrix34d ApplyCorotatedStiffness(const TetRestShape& rest, const LameParameters& lame,
                                  const Eigen::Matrix3d& R, const Matrix34d& p) {
  // local displacement gradient of R^T p, local stress, rotated back
  const Eigen::Matrix3d G = R.transpose() * (p * rest.grad_n.transpose());
  const Eigen::Matrix3d P = R * LinearStress(lame, G);
  return rest.volume * P * rest.grad_n;
}

Matrix34d CalcCorotatedForce(const TetRestShape& rest, const LameParameters& lame,
                             const Eigen::Matrix3d& R, const Eigen::Matrix3d& F) {
  // u = R^T x - X has displacement gradient R^T F - I (sum_a g_a = 0, sum_a X_a g_a^T = I)
  Eigen::Matrix3d G = R.transpose() * F;
  G.diagonal().array() -= 1.0;
  const Eigen::Matrix3d P = R * LinearStress(lame, G);
  return -rest.volume * P * rest.grad_n;
}

Matrix34d CalcCorotatedStepLoad(const TetRestShape& rest, const LameParameters& lame,
                                const Matrix34d& rotated_grad, const Matrix34d& x,
                                const Matrix34d& w, double h, double c) {
  // F R^T = sum_a x_a r_a^T (the stretch in the world frame), K w's gradient sum_a w_a r_a^T;
  // R sigma(R^T Y) g_a = sigma(Y R^T) r_a for the isotropic linear stress
  Eigen::Matrix3d G = (h * x.col(0) + c * w.col(0)) * rotated_grad.col(0).transpose();
  for (int a = 1; a < 4; ++a)
    G.noalias() += (h * x.col(a) + c * w.col(a)) * rotated_grad.col(a).transpose();
  G.diagonal().array() -= h;
  return -rest.volume * LinearStress(lame, G) * rotated_grad;
}

double CalcCorotatedEnergy(const TetRestShape& rest, const LameParameters& lame,
                           const Eigen::Matrix3d& R, const Eigen::Matrix3d& F) {
  Eigen::Matrix3d G = R.transpose() * F;
  G.diagonal().array() -= 1.0;
  const Eigen::Matrix3d eps = 0.5 * (G + G.transpose());
  const double tr = eps.trace();
  return rest.volume * (lame.mu * eps.squaredNorm() + 0.5 * lame.lambda * tr * tr);
}

}  // namespace nsim
