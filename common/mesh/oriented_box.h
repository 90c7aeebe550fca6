#pragma once
// A rigid oriented box (a rib, the diaphragm region, an anchor region of a liver, the patient's or
// the controller model's): point containment, signed distance and the closest boundary point
// with its outward normal.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

namespace nsim {

/// An oriented box B: centre p_WB (m), rotation R_WB (columns = box axes in world) and
/// half-sizes along its own axes (m).
struct OrientedBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();             ///< p_WB (m)
  Eigen::Vector3d half_size = Eigen::Vector3d::Constant(0.01);  ///< along x_B, y_B, z_B (m), > 0
  Eigen::Matrix3d R_WB = Eigen::Matrix3d::Identity();           ///< orientation in world

  /// Throws InputError "<name>.half_size must be > 0 (m), got ..." (and for non-finite values).
  void Validate(const std::string& name) const;

  /// True if p_W (m) lies inside or on the box.
  bool Contains(const Eigen::Vector3d& p_W) const;
};

/// Closest point of the box boundary to a query point.
struct BoxProximity {
  double signed_distance = 0.0;                   ///< > 0 outside, < 0 inside (m)
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< closest boundary point (m)
  /// Outward unit normal at p_W: (query - p_W) / |query - p_W| outside; the normal of the face
  /// of least penetration inside.
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitX();
};

/// Signed distance, closest boundary point and outward normal of `box` for p_W (m).
BoxProximity CalcBoxProximity(const OrientedBox& box, const Eigen::Vector3d& p_W);

}  // namespace nsim
