#pragma once
// Rigid-motion helpers shared by the robots and the controller: SO(3) exponential and logarithm,
// the inverse right Jacobian of SO(3), and 6-vector pose increments.
//
// Convention for every 6-vector in nsim::robot and nsim::control (twists, pose increments,
// Jacobian rows and columns): LINEAR FIRST, then angular, [v; w] (Siciliano's ordering, not
// Drake's [w; v]). Use kLinear / kAngular with segment<3>() rather than bare indices.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace nsim {

/// A 6-vector [linear (3); angular (3)].
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Offset of the linear part in a 6-vector.
inline constexpr int kLinear = 0;
/// Offset of the angular part in a 6-vector.
inline constexpr int kAngular = 3;

/// The frame in which a pose increment [dp; dtheta] (m; rad) is expressed.
enum class PoseIncrementFrame {
  /// World-aligned axes at the origin of E: p' = p + dp, R' = Exp(dtheta) R. A rotation
  /// increment turns E about its own origin around a world axis.
  kWorldAligned,
  /// Body axes of E: p' = p + R dp, R' = R Exp(dtheta).
  kBody,
};

/// The skew-symmetric matrix [w]x with [w]x v = w x v.
Eigen::Matrix3d Skew(const Eigen::Vector3d& w);

/// Exponential map of SO(3): the rotation of angle |w| (rad) about w / |w|. Exact for any |w|;
/// uses the second-order series below |w| = 1e-8 rad.
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w);

/// Logarithm of SO(3): the rotation vector w (rad) with ExpSO3(w) = R and |w| in [0, pi].
/// Accurate near 0 and near pi (uses the symmetric part of R when cos(angle) < 0). At exactly
/// pi the sign of the axis is ambiguous; either is returned. R must be a rotation matrix.
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R);

/// Inverse right Jacobian of SO(3): LogSO3(ExpSO3(phi) ExpSO3(d)) = phi + JrInv(phi) d + O(d^2).
/// JrInv = I + [phi]x / 2 + (1 / t^2 - (1 + cos t) / (2 t sin t)) [phi]x^2, t = |phi| < pi.
Eigen::Matrix3d CalcSO3RightJacobianInverse(const Eigen::Vector3d& phi);

/// Applies the increment delta = [dp (m); dtheta (rad)] to the pose X_WE in `frame`.
Eigen::Isometry3d ApplyPoseIncrement(const Eigen::Isometry3d& X_WE, const Vector6d& delta,
                                     PoseIncrementFrame frame);

/// The increment that takes X_WB to X_WA in `frame`: ApplyPoseIncrement(X_WB, d, frame) = X_WA,
/// with |dtheta| <= pi. Units m; rad.
Vector6d CalcPoseDifference(const Eigen::Isometry3d& X_WA, const Eigen::Isometry3d& X_WB,
                            PoseIncrementFrame frame);

/// Angle (rad, in [0, pi]) of the relative rotation between R_A and R_B.
double CalcRotationAngle(const Eigen::Matrix3d& R_A, const Eigen::Matrix3d& R_B);

/// True if every entry of the pose is finite.
bool IsFinitePose(const Eigen::Isometry3d& X);

/// True if the pose is finite and its linear part is a rotation: |R^T R - I| <= tolerance
/// (max-abs entry) and det R > 0.
bool IsRigidTransform(const Eigen::Isometry3d& X, double tolerance = 1e-9);

}  // namespace nsim
