#pragma once
// A material point of a tetrahedral mesh: a tetrahedron and barycentric coordinates in it.
// It moves with the mesh: evaluating it on deformed positions gives where the point went
// (constraint points live in tetrahedra this way, without remeshing).

#include <Eigen/Core>
#include <vector>

#include "common/mesh/tet_mesh.h"

namespace nsim {

/// A point inside (or on) tetrahedron `tet`: p = sum_k bary[k] x(tets[tet][k]), sum bary = 1.
struct TetPoint {
  int tet = -1;                                    ///< index into TetMesh::tets
  Eigen::Vector4d bary = Eigen::Vector4d::Zero();  ///< barycentric weights (dimensionless)
};

/// Barycentric coordinates of p with respect to tetrahedron (a, b, c, d); they sum to 1 and
/// are all >= 0 exactly when p is inside. Precondition: the tetrahedron is not degenerate.
Eigen::Vector4d CalcBarycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                const Eigen::Vector3d& d);

/// Position of `point` on node positions `x` (3 x #nodes, m) of `mesh` (rest or deformed).
Eigen::Vector3d EvalTetPoint(const TetMesh& mesh, const Eigen::Matrix3Xd& x, const TetPoint& point);

/// Same with the connectivity alone.
inline Eigen::Vector3d EvalTetPoint(const std::vector<Eigen::Vector4i>& tets,
                                    const Eigen::Matrix3Xd& x, const TetPoint& point) {
  const Eigen::Vector4i& t = tets[point.tet];
  return point.bary[0] * x.col(t[0]) + point.bary[1] * x.col(t[1]) + point.bary[2] * x.col(t[2]) +
         point.bary[3] * x.col(t[3]);
}

}  // namespace nsim
