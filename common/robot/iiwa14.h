#pragma once
// KUKA LBR iiwa 14 R820 kinematics (thesis appendix A; numbers from REFERENCE.md, ROS-Industrial
// kuka_experimental lbr_iiwa_14_r820_macro.xacro): forward kinematics of every link frame, the
// flange and a tool, the geometric Jacobian, and the joint limits.
//
// Chain (base B = link 0; every joint origin has rpy 0, so link i is its parent translated by
// the origin offset, then rotated by q_i about the joint axis):
//   a1: (0, 0, 0),    z    a2: (0, 0, 0.36), y    a3: (0, 0, 0),    z    a4: (0, 0, 0.42), -y
//   a5: (0, 0, 0),    z    a6: (0, 0, 0.40), y    a7: (0, 0, 0),    z    flange F: (0, 0, 0.126)
// The URDF's +-0.436 mm x offsets at a2 and a4 (CAD residue) are left out, as in Drake's model.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

#include "common/robot/pose_math.h"

namespace nsim {

/// Number of joints of the iiwa.
inline constexpr int kIiwaNumJoints = 7;

/// Joint-space 7-vector (rad, rad/s or rad/s^2 as the name says).
using Vector7d = Eigen::Matrix<double, 7, 1>;

/// Geometric Jacobian, 6 x 7: rows [linear velocity (m/s); angular velocity (rad/s)] in W, per
/// unit joint rate (rad/s).
using Jacobian67 = Eigen::Matrix<double, 6, 7>;

/// Placement, tool and limits of the iiwa. SI units.
struct Iiwa14Config {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();  ///< robot base B in world W
  Eigen::Isometry3d X_FT = Eigen::Isometry3d::Identity();  ///< tool T (needle) in flange F
  /// joint position limits (rad), lower < upper
  Vector7d position_lower =
      (Vector7d() << -2.9668, -2.0942, -2.9668, -2.0942, -2.9668, -2.0942, -3.0541).finished();
  Vector7d position_upper =
      (Vector7d() << 2.9668, 2.0942, 2.9668, 2.0942, 2.9668, 2.0942, 3.0541).finished();
  /// joint speed limits (rad/s), > 0
  Vector7d velocity_limit =
      (Vector7d() << 1.4834, 1.4834, 1.7452, 1.3089, 2.2688, 2.356, 2.356).finished();
  /// joint acceleration limits (rad/s^2), > 0 (Drake's iiwa14 model)
  Vector7d acceleration_limit =
      (Vector7d() << 8.57, 8.57, 8.74, 11.36, 12.23, 15.72, 15.72).finished();

  /// Throws InputError naming the first invalid field, e.g.
  /// "iiwa.velocity_limit[2] must be > 0 (rad/s), got 0".
  void Validate() const;
};

/// Result of forward kinematics for one q: every frame in world, joint axes and origins.
/// Fixed size, cheap to copy.
struct Iiwa14Kinematics {
  Vector7d q = Vector7d::Zero();  ///< the joint angles these frames are for (rad)
  std::array<Eigen::Isometry3d, kIiwaNumJoints> X_WL;  ///< link i+1 frame in W (after joint i+1)
  std::array<Eigen::Vector3d, kIiwaNumJoints> a_W;     ///< unit axis of joint i+1 in W
  std::array<Eigen::Vector3d, kIiwaNumJoints> p_WJ;    ///< origin of joint i+1 in W (m)
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();  ///< flange in W
  Eigen::Isometry3d X_WT = Eigen::Isometry3d::Identity();  ///< tool in W (X_WF X_FT)
};

/// The iiwa's immutable kinematic model.
class Iiwa14Model {
 public:
  /// Joint origins in the parent link (m), see the file comment.
  static const std::array<Eigen::Vector3d, kIiwaNumJoints>& JointOrigins();
  /// Joint axes in their own link frame (unit).
  static const std::array<Eigen::Vector3d, kIiwaNumJoints>& JointAxes();
  /// Flange offset from link 7 (m): (0, 0, 0.126).
  static Eigen::Vector3d FlangeOffset() { return Eigen::Vector3d(0.0, 0.0, 0.126); }

  /// Validates `config` (throws InputError).
  explicit Iiwa14Model(const Iiwa14Config& config = Iiwa14Config());

  const Iiwa14Config& config() const { return config_; }

  /// Forward kinematics of every frame at q (rad). No allocation.
  void CalcForwardKinematics(const Vector7d& q, Iiwa14Kinematics* kinematics) const;

  /// Flange pose in the base frame, X_BF(q).
  Eigen::Isometry3d CalcFlangePoseInBase(const Vector7d& q) const;

  /// Tool pose in world, X_WT(q) = X_WB X_BF(q) X_FT.
  Eigen::Isometry3d CalcToolPose(const Vector7d& q) const;

  /// Geometric Jacobian of the point P (fixed to link 7) at p_WP (m), in W: [v_WP; w_W7] =
  /// J qdot, column i = [a_i x (p_WP - p_WJi); a_i]. No allocation.
  void CalcJacobian(const Iiwa14Kinematics& kinematics, const Eigen::Vector3d& p_WP,
                    Jacobian67* J) const;

  /// The Jacobian at the tool point p_WT.
  void CalcToolJacobian(const Iiwa14Kinematics& kinematics, Jacobian67* J) const {
    CalcJacobian(kinematics, kinematics.X_WT.translation(), J);
  }

  /// q clamped into the position limits.
  Vector7d ClampToLimits(const Vector7d& q) const;

  /// True if lower - tolerance <= q <= upper + tolerance on every joint (rad); false for NaN.
  bool IsWithinLimits(const Vector7d& q, double tolerance = 0.0) const;

  /// Middle of each joint range (rad).
  Vector7d CalcMidRange() const;

 private:
  Iiwa14Config config_;
};

}  // namespace nsim
