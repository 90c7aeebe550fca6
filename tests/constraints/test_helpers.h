#pragma once
// Small bodies shared by the constraint tests.

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "common/constraints/dense_linear_body.h"

namespace nsim::testing {

/// Stiffness (N/m) of isotropic linear springs k (x_j - x_i) between node pairs: a graph
/// Laplacian times I3, positive semi-definite and translation invariant.
inline Eigen::MatrixXd MakeSpringStiffness(int n, const std::vector<std::pair<int, int>>& springs,
                                           double k) {
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (const auto& [i, j] : springs) {
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity() * k;
    K.block<3, 3>(3 * i, 3 * i) += I;
    K.block<3, 3>(3 * j, 3 * j) += I;
    K.block<3, 3>(3 * i, 3 * j) -= I;
    K.block<3, 3>(3 * j, 3 * i) -= I;
  }
  return K;
}

/// Free particles with equal masses (kg) at the given positions (m).
inline DenseLinearBodyConfig MakeParticleConfig(const Eigen::Matrix3Xd& x, double mass, double h,
                                                const Eigen::Vector3d& g) {
  DenseLinearBodyConfig c;
  c.masses = Eigen::VectorXd::Constant(x.cols(), mass);
  c.rest_positions = x;
  c.time_step = h;
  c.gravity = g;
  return c;
}

/// A chain of n particles along x with spacing `dx` (m), springs k (N/m) between neighbours and
/// also between second neighbours (so the stiffness is fully coupled).
inline DenseLinearBodyConfig MakeChainConfig(int n, double mass, double dx, double k, double h,
                                             const Eigen::Vector3d& origin,
                                             const Eigen::Vector3d& g) {
  Eigen::Matrix3Xd x(3, n);
  for (int i = 0; i < n; ++i) x.col(i) = origin + Eigen::Vector3d(dx * i, 0.0, 0.0);
  std::vector<std::pair<int, int>> springs;
  for (int i = 0; i + 1 < n; ++i) springs.emplace_back(i, i + 1);
  for (int i = 0; i + 2 < n; ++i) springs.emplace_back(i, i + 2);
  DenseLinearBodyConfig c = MakeParticleConfig(x, mass, h, g);
  c.stiffness = MakeSpringStiffness(n, springs, k);
  return c;
}

}  // namespace nsim::testing
