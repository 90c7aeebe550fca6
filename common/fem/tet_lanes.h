#pragma once
// Tetrahedra side by side: the element kernels of FemSolver's hot loops (its matrix-free
// product and the element pass's step load) on kTetLanes elements at once. Entry i of every
// element's matrix lives in one TetLanes (one AVX2 vector of doubles), so that a kernel's
// arithmetic is the one-element formula with each scalar replaced by a vector across the
// elements; only the gathers of the nodal vectors and the scatters of the results stay one
// element at a time.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <vector>

#include "common/fem/fem_config.h"

namespace nsim {

struct TetRestShape;

/// W doubles, one per element (a lane each), and a 3 x 3 matrix of W elements, entry (i, j)
/// of lane l's matrix in m[3 j + i][l] (column-major, as one element's Matrix3d).
template <int W>
using Lanes = Eigen::Array<double, W, 1>;
template <int W>
using Matrix3Lanes = std::array<Lanes<W>, 9>;

/// Elements a TetLanes holds (a 256-bit vector of doubles).
inline constexpr int kTetLanes = 4;
using TetLanes = Lanes<kTetLanes>;

/// A 3 x 4 matrix of kTetLanes elements (shape-function gradients, nodal vectors): entry (c, a)
/// of lane l's matrix in m[3 a + c][l], the column-major order of one element's Matrix34d.
using TetLanes34 = std::array<TetLanes, 12>;
/// A 3 x 3 matrix of kTetLanes elements.
using TetLanes33 = Matrix3Lanes<kTetLanes>;

/// sum_a u_a r_a^T of kTetLanes elements (a deformation or displacement gradient: u the nodal
/// vectors, r the shape-function gradients).
inline TetLanes33 OuterSumLanes(const TetLanes34& u, const TetLanes34& r) {
  TetLanes33 g;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      TetLanes sum = u[i] * r[j];
      for (int a = 1; a < 4; ++a) sum += u[3 * a + i] * r[3 * a + j];
      g[3 * j + i] = sum;
    }
  return g;
}

/// The isotropic linear stress's nodal vectors of kTetLanes elements with gradients r
/// (r_a = R g_a, the rotated shape-function gradients, or g_a at rest): for the nodal input u,
/// G = sum_a u_a r_a^T - shift I and y_a = scale (lambda tr(G) I + mu (G + G^T)) r_a, each lane
/// with its own scale (the element's volume times a factor; 0 for a lane without an element).
/// With shift = 0 and scale = V it is R K_e R^T u (ApplyCorotatedStiffness); with
/// u = h x + c w, shift = h and scale = -V it is the step load (CalcCorotatedStepLoad).
inline TetLanes34 ApplyStressLanes(const TetLanes34& r, const TetLanes& scale,
                                   const LameParameters& lame, double shift,
                                   const TetLanes34& u) {
  TetLanes33 g = OuterSumLanes(u, r);
  for (int i = 0; i < 3; ++i) g[4 * i] -= shift;
  // scale sigma, symmetric: its diagonal and its three entries above it
  const TetLanes mu = scale * lame.mu;
  const TetLanes trace = scale * lame.lambda * (g[0] + g[4] + g[8]);
  TetLanes s[9];
  for (int i = 0; i < 3; ++i) s[4 * i] = trace + 2.0 * mu * g[4 * i];
  s[3] = s[1] = mu * (g[3] + g[1]);
  s[6] = s[2] = mu * (g[6] + g[2]);
  s[7] = s[5] = mu * (g[7] + g[5]);
  TetLanes34 y;
  for (int a = 0; a < 4; ++a)
    for (int i = 0; i < 3; ++i)
      y[3 * a + i] = s[i] * r[3 * a] + s[3 + i] * r[3 * a + 1] + s[6 + i] * r[3 * a + 2];
  return y;
}

/// The rotated gradients r_a = R g_a of kTetLanes elements, R column-major in rotation[3 j + i].
inline TetLanes34 RotateLanes(const TetLanes33& rotation, const TetLanes34& grad) {
  TetLanes34 r;
  for (int a = 0; a < 4; ++a)
    for (int i = 0; i < 3; ++i)
      r[3 * a + i] = rotation[i] * grad[3 * a] + rotation[3 + i] * grad[3 * a + 1] +
                     rotation[6 + i] * grad[3 * a + 2];
  return r;
}

/// The mesh's tetrahedra in blocks of kTetLanes consecutive elements (block b: elements
/// kTetLanes b + l), the last block padded with lanes that repeat its first element's nodes
/// and have zero volume and gradients (they add nothing).
struct TetBlocks {
  std::vector<std::array<Eigen::Vector4i, kTetLanes>> nodes;  ///< [block][lane]: the 4 node indices
  std::vector<TetLanes> volume;                               ///< [block]: rest volumes (m^3)
  std::vector<TetLanes34> grad;                               ///< [block]: rest gradients g_a (1/m)
  int num_tets = 0;

  int num_blocks() const { return static_cast<int>(nodes.size()); }
};

/// The blocks of the tetrahedra `tets` with rest shapes `rest` (the same length).
TetBlocks MakeTetBlocks(const std::vector<Eigen::Vector4i>& tets,
                        const std::vector<TetRestShape>& rest);

/// The nodal vectors of block b's elements (padding lanes: their repeated node's), from the
/// columns of `nodal` (3 x #nodes).
inline TetLanes34 GatherLanes(const TetBlocks& blocks, int b, const Eigen::Matrix3Xd& nodal) {
  static_assert(kTetLanes == 4, "one TetLanes constructor argument a lane");
  const auto& n = blocks.nodes[b];
  TetLanes34 u;
  for (int a = 0; a < 4; ++a)
    for (int c = 0; c < 3; ++c)
      u[3 * a + c] = TetLanes(nodal(c, n[0][a]), nodal(c, n[1][a]), nodal(c, n[2][a]),
                              nodal(c, n[3][a]));
  return u;
}

/// nodal.col(node a of element l) += y_a of lane l, for block b's elements (not its padding).
inline void ScatterAddLanes(const TetBlocks& blocks, int b, const TetLanes34& y,
                            Eigen::Matrix3Xd& nodal) {
  const int lanes = std::min(kTetLanes, blocks.num_tets - kTetLanes * b);
  for (int l = 0; l < lanes; ++l)
    for (int a = 0; a < 4; ++a) {
      double* column = nodal.col(blocks.nodes[b][l][a]).data();
      for (int c = 0; c < 3; ++c) column[c] += y[3 * a + c][l];
    }
}

/// Element e's 3 x 4 matrix from per-block lanes (block e / kTetLanes, lane e % kTetLanes).
inline Eigen::Matrix<double, 3, 4> ElementOfLanes(const std::vector<TetLanes34>& lanes, int e) {
  Eigen::Matrix<double, 3, 4> m;
  for (int i = 0; i < 12; ++i) m(i) = lanes[e / kTetLanes][i][e % kTetLanes];
  return m;
}

}  // namespace nsim
