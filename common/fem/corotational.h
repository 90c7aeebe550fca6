#pragma once
// Co-rotational linear tetrahedron: rest shape, polar rotation, element force, stiffness and
// strain energy (Müller & Gross 2004; Irving et al. 2004 for inverted elements).
//
// Conventions: the 4 node positions of an element are the columns of a 3 x 4 matrix; the
// displacement vector of an element stacks node 0 (x, y, z), node 1, ..., node 3 (12 entries).
// K_e is the positive semi-definite rest stiffness (N/m); the elastic force is
// f_e = -R_e K_e (R_e^T x_e - X_e) (N), DESIGN.md "Physics".

#include <Eigen/Core>

#include "common/fem/fem_config.h"
#include "common/fem/tet_lanes.h"

namespace nsim {

using Matrix34d = Eigen::Matrix<double, 3, 4>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// Rest data of one linear tetrahedron, precomputed once. The rest stiffness is stored in
/// factored form: K_e = V B^T D B is entirely given by (volume, grad_n) and the Lamé parameters,
/// K_ab = V (lambda g_a g_b^T + mu g_b g_a^T + mu (g_a . g_b) I), g_a = grad_n.col(a). The factored
/// form holds 13 numbers instead of 144, and R K_e R^T costs a quarter of the dense product.
struct TetRestShape {
  Matrix34d grad_n = Matrix34d::Zero();  ///< column a: gradient of shape function N_a at rest (1/m)
  double volume = 0.0;                   ///< rest volume V (m^3), > 0
};

/// Rest shape of the tetrahedron with rest node positions X (3 x 4, m). Throws InputError when
/// the rest volume is not positive (degenerate or negatively oriented element).
TetRestShape CalcTetRestShape(const Matrix34d& X);

/// Deformation gradient F = sum_a x_a g_a^T (-) of the element with node positions x (3 x 4, m).
Eigen::Matrix3d CalcDeformationGradient(const TetRestShape& rest, const Matrix34d& x);

/// Rotation R of the polar decomposition F = R S (S symmetric positive definite) when
/// det F > kPolarSvdThreshold, computed by Higham's scaled Newton iteration until a step is
/// below kPolarStepTolerance, so within kPolarStepTolerance^2 (Frobenius) of the exact factor.
/// Otherwise (nearly degenerate or inverted element) by SVD F = U Sigma V^T with the sign of the
/// smallest singular value flipped so that det R = +1 (Irving et al. 2004). Always a rotation.
/// `used_svd`, when given, reports whether the SVD branch ran.
Eigen::Matrix3d CalcPolarRotation(const Eigen::Matrix3d& F, bool* used_svd = nullptr);

/// CalcPolarRotation of F[0..count) into R[0..count) (used_svd[k]: whether F[k] took the SVD
/// branch), kTetLanes matrices at once in the Newton iteration: the same rotations as one call
/// each (each matrix stops where it would alone), in under half the time of one-by-one calls
/// before the batches (fem_bench PolarRotation: the 2660-node liver's elements 0.47 against
/// 1.0 ms). FemSolver's nodal rotations call it. (8 lanes measured slower than 4: a block
/// iterates until its slowest matrix stops.)
void CalcPolarRotations(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, bool* used_svd, int count);

/// The same for the kTetLanes matrices in x (entry i of lane l's matrix, column-major, in
/// x[i][l]), in place: x holds their rotations on return. Lanes l < m hold matrices
/// (used_svd[l] set); the others are ignored. FemSolver's element pass calls it.
void CalcPolarRotationLanes(TetLanes33& x, int m, bool* used_svd);

/// det F at or below which CalcPolarRotation uses the SVD branch (-).
inline constexpr double kPolarSvdThreshold = 1e-3;

/// Frobenius norm of the Newton step below which CalcPolarRotation stops (-): the rotation is
/// then within 1e-8 of the polar factor (about half that at worst), 1e4 times below the FEM
/// solver's PCG tolerance (1e-4), and most elements of a breathing liver stop one iteration
/// earlier than at machine precision (2.2 instead of 2.9 iterations an element in the patient
/// scene; docs/performance.md).
inline constexpr double kPolarStepTolerance = 1e-4;

/// Dense 12 x 12 co-rotated stiffness R K_e R^T (N/m); R = I gives the rest stiffness K_e.
Matrix12d CalcCorotatedStiffness(const TetRestShape& rest, const LameParameters& lame,
                                 const Eigen::Matrix3d& R);

/// Matrix-free product R K_e R^T p for nodal vectors p (3 x 4); returns 3 x 4 (N when p in m).
Matrix34d ApplyCorotatedStiffness(const TetRestShape& rest, const LameParameters& lame,
                                  const Eigen::Matrix3d& R, const Matrix34d& p);

/// Elastic force f = -R K_e (R^T x - X) on the 4 nodes (3 x 4, N) at positions x (3 x 4, m),
/// given the deformation gradient F of x and the element rotation R. R = I is the small-strain
/// (linear) element, R = CalcPolarRotation(F) the co-rotational one.
Matrix34d CalcCorotatedForce(const TetRestShape& rest, const LameParameters& lame,
                             const Eigen::Matrix3d& R, const Eigen::Matrix3d& F);

/// The element's share of implicit Euler's right-hand side, h f - c R K_e R^T w (3 x 4, N s),
/// for positions x (3 x 4, m), end velocities w (3 x 4, m/s), step h (s) and c = h beta + h^2
/// (s^2), in one stress evaluation: the linear stress is linear in the displacement gradient,
/// so with the rotated gradients r_a = R g_a (rotated_grad = R rest.grad_n) it is
/// -V sigma(sum_a (h x_a + c w_a) r_a^T - h I) r_a, sigma(G) = lambda tr(G) I + mu (G + G^T).
/// Equals h CalcCorotatedForce - c ApplyCorotatedStiffness to round-off.
Matrix34d CalcCorotatedStepLoad(const TetRestShape& rest, const LameParameters& lame,
                                const Matrix34d& rotated_grad, const Matrix34d& x,
                                const Matrix34d& w, double h, double c);

/// Strain energy (J) 0.5 u^T K_e u with u = R^T x - X, i.e. V (mu eps:eps + lambda/2 tr(eps)^2),
/// eps = sym(R^T F) - I. With the polar R its gradient is exactly -CalcCorotatedForce.
double CalcCorotatedEnergy(const TetRestShape& rest, const LameParameters& lame,
                           const Eigen::Matrix3d& R, const Eigen::Matrix3d& F);

}  // namespace nsim
