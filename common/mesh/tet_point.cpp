#include "common/mesh/tet_point.h"

#include <Eigen/LU>

#include "common/core/error.h"

namespace nsim {

Eigen::Vector4d CalcBarycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                const Eigen::Vector3d& d) {
  Eigen::Matrix3d m;
  m << b - a, c - a, d - a;
  const Eigen::Vector3d w = m.partialPivLu().solve(p - a);
  return {1.0 - w.sum(), w[0], w[1], w[2]};
}

Eigen::Vector3d EvalTetPoint(const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                             const TetPoint& point) {
  NSIM_CHECK(point.tet >= 0 && point.tet < mesh.num_tets(), "tet index ", point.tet,
             " out of range");
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  return EvalTetPoint(mesh.tets, x, point);
}

}  // namespace nsim
