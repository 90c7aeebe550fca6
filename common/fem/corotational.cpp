#include "common/fem/corotational.h"

#include <Eigen/Dense>
#include <algorithm>
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

namespace {

// Higham's Newton iteration X <- (g X + (g X)^-T) / 2 with determinant scaling g, on W
// matrices at once (det > 0 each). x[i] holds entry i (column-major) of every lane's matrix,
// so that each array operation below is one vector operation across the lanes; a lane stops
// where the iteration on its matrix alone would (its iterate is then kept), the block when
// every lane has. It converges quadratically to the orthogonal polar factor, a rotation as
// det > 0.
template <int W>
void PolarNewton(Matrix3Lanes<W>& x, Lanes<W> det) {
  using A = Lanes<W>;
  A done = A::Zero();  // 1 for a lane that has stopped
  for (int it = 0; it < 30; ++it) {
    // X^-T = cofactor(X) / det X, the cofactor's columns the crosses of X's columns
    A cof[9];
    for (int c = 0; c < 3; ++c) {
      const int a = 3 * ((c + 1) % 3), b = 3 * ((c + 2) % 3);
      for (int r = 0; r < 3; ++r) {
        const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
        cof[3 * c + r] = x[a + r1] * x[b + r2] - x[a + r2] * x[b + r1];
      }
    }
    if (it > 0) det = x[0] * cof[0] + x[1] * cof[1] + x[2] * cof[2];
    // |det(gX)| = 1; near-orthogonal iterates need no scaling (saves the cube root)
    // (g = det^(-1/3) as exp(-log(det) / 3), across the lanes at once)
    A g = A::Ones();
    const auto far = (det - 1.0).abs() >= 1e-2;
    if (far.any()) g = far.select((det.log() * (-1.0 / 3.0)).exp(), g);
    const A inv = (g * det).inverse();
    A change = A::Zero();
    for (int i = 0; i < 9; ++i) {
      const A next = 0.5 * (g * x[i] + inv * cof[i]);
      change += (next - x[i]).square();
      x[i] = (done > 0.5).select(x[i], next);
    }
    // X = Q (I + E), E symmetric, becomes Q (I + E^2 / 2 + O(E^3)) in a step that changes
    // X by ||E||: after a step of norm below kPolarStepTolerance the iterate is within
    // about kPolarStepTolerance^2 / 2 of the polar factor (E^2 / 2 plus higher orders)
    done = (change < kPolarStepTolerance * kPolarStepTolerance).select(A::Ones(), done);
    if ((done > 0.5).all()) break;
  }
}

// the SVD branch: F = U Sigma V^T, the smallest singular value's sign flipped so that the
// factor is a proper rotation (Irving et al. 2004)
Eigen::Matrix3d PolarRotationBySvd(const Eigen::Matrix3d& F) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  // singular values are sorted decreasing: flip the last column to make both proper rotations
  if (U.determinant() < 0) U.col(2) = -U.col(2);
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  return U * V.transpose();
}

// the polar rotations of the W matrices in x (entry i of lane l in x[i][l]; R on return) whose
// lanes below m hold matrices, in one block of PolarNewton; the lanes past m and those for the
// SVD branch (det F <= kPolarSvdThreshold, computed apart) iterate on I (one step, no change)
template <int W>
void PolarLanes(Matrix3Lanes<W>& x, int m, bool* used_svd) {
  // det = x_0 . (x_1 x x_2), the columns x_c = (x[3c], x[3c + 1], x[3c + 2])
  Lanes<W> det = x[0] * (x[4] * x[8] - x[5] * x[7]) + x[1] * (x[5] * x[6] - x[3] * x[8]) +
                 x[2] * (x[3] * x[7] - x[4] * x[6]);
  bool any_svd = false;
  Eigen::Matrix3d F[W];  // the SVD branch's matrices
  for (int l = 0; l < W; ++l) {
    const bool newton = l < m && det[l] > kPolarSvdThreshold;
    if (l < m) used_svd[l] = !newton;
    if (newton) continue;
    if (l < m) {
      any_svd = true;
      for (int i = 0; i < 9; ++i) F[l](i) = x[i][l];
    }
    for (int i = 0; i < 9; ++i) x[i][l] = i % 4 == 0 ? 1.0 : 0.0;
    det[l] = 1.0;
  }
  PolarNewton<W>(x, det);
  if (!any_svd) return;
  for (int l = 0; l < m; ++l)
    if (used_svd[l]) {
      const Eigen::Matrix3d R = PolarRotationBySvd(F[l]);
      for (int i = 0; i < 9; ++i) x[i][l] = R(i);
    }
}

// PolarLanes for the matrices F[0..m), m <= W, into R[0..m)
template <int W>
void PolarBlock(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, bool* used_svd, int m) {
  Matrix3Lanes<W> x;
  for (int l = 0; l < W; ++l)
    for (int i = 0; i < 9; ++i) x[i][l] = l < m ? F[l](i) : 0.0;
  PolarLanes<W>(x, m, used_svd);
  for (int l = 0; l < m; ++l)
    for (int i = 0; i < 9; ++i) R[l](i) = x[i][l];
}

}  // namespace

Eigen::Matrix3d CalcPolarRotation(const Eigen::Matrix3d& F, bool* used_svd) {
  Eigen::Matrix3d R;
  bool svd = false;
  PolarBlock<1>(&F, &R, &svd, 1);
  if (used_svd) *used_svd = svd;
  return R;
}

void CalcPolarRotations(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, bool* used_svd, int count) {
  for (int begin = 0; begin < count; begin += kTetLanes)
    PolarBlock<kTetLanes>(F + begin, R + begin, used_svd + begin,
                          std::min(kTetLanes, count - begin));
}

void CalcPolarRotationLanes(TetLanes33& x, int m, bool* used_svd) {
  PolarLanes<kTetLanes>(x, m, used_svd);
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
