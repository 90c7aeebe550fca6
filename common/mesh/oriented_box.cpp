#include "common/mesh/oriented_box.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {

void OrientedBox::Validate(const std::string& name) const {
  if (!center.allFinite())
    throw InputError(Str(name, ".center must be finite (m), got ", center.transpose()));
  if (!(half_size.minCoeff() > 0) || !half_size.allFinite())
    throw InputError(Str(name, ".half_size must be > 0 (m), got ", half_size.transpose()));
  // boxes of a patient scene (ribs, diaphragm, anchors): 10 m is far outside any body
  CheckNormAtMost(center, 10.0, name + ".center", "m");
  CheckAtMost(half_size.maxCoeff(), 10.0, name + ".half_size", "m");
  if (!R_WB.allFinite() || !(std::abs(R_WB.determinant() - 1.0) < 1e-6))
    throw InputError(Str(name, ".rpy must give a rotation"));
}

bool OrientedBox::Contains(const Eigen::Vector3d& p_W) const {
  const Eigen::Vector3d p_B = R_WB.transpose() * (p_W - center);
  return (p_B.cwiseAbs().array() <= half_size.array()).all();
}

BoxProximity CalcBoxProximity(const OrientedBox& box, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d p_B = box.R_WB.transpose() * (p_W - box.center);
  const Eigen::Vector3d excess = p_B.cwiseAbs() - box.half_size;  // > 0: outside on that axis
  BoxProximity out;
  if ((excess.array() > 0).any()) {
    // outside: clamp into the box; the normal points from the box to the query
    const Eigen::Vector3d q_B = p_B.cwiseMax(-box.half_size).cwiseMin(box.half_size);
    const Eigen::Vector3d d_B = p_B - q_B;
    out.signed_distance = d_B.norm();
    out.p_W = box.center + box.R_WB * q_B;
    out.normal_W = box.R_WB * (d_B / out.signed_distance);
    return out;
  }
  // inside: the face of least penetration
  int axis = 0;
  excess.maxCoeff(&axis);
  const double side = p_B[axis] >= 0 ? 1.0 : -1.0;
  Eigen::Vector3d q_B = p_B;
  q_B[axis] = side * box.half_size[axis];
  out.signed_distance = excess[axis];
  out.p_W = box.center + box.R_WB * q_B;
  out.normal_W = box.R_WB.col(axis) * side;
  return out;
}

}  // namespace nsim
