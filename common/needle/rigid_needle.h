#pragma once
// The needle held by the robot: geometry, the tool offset from the flange, and the rigid
// (kinematic) needle of thesis §5.2. The needle frame N has its origin at the needle base and
// its z axis along the needle, from the base towards the tip; x_N and y_N are the reference
// lateral directions (the bevel side at bevel_angle 0 is +y_N, see bevel_tip.h).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

namespace nsim {

/// Geometry, material and mounting of a needle (rigid or flexible). SI units.
struct NeedleConfig {
  double length = 0.13;          ///< L (m), base to tip, > 0 (thesis §5.2 rigid needle)
  double radius = 0.723e-3;      ///< outer radius r (m), > 0 (solid circular section)
  double young_modulus = 200e9;  ///< E (Pa), > 0 (rigid needle: informational)
  double poisson_ratio = 0.45;   ///< nu (-), in (-1, 0.5) (thesis §5.2-5.3)
  double density = 7850.0;       ///< rho (kg/m^3), > 0 (steel)
  /// Position of the needle base in the flange frame F (m): the tool offset.
  Eigen::Vector3d p_FBase = Eigen::Vector3d::Zero();
  /// Needle direction (base to tip) in the flange frame F, nonzero (normalized on use).
  Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ();

  /// Throws InputError "<prefix>.<key> must be ..., got <value>" for the first invalid field.
  void Validate(const std::string& prefix = "needle") const;
};

/// Pose of the needle frame N in the flange frame F: origin p_FBase, z_N = axis_F normalized,
/// x_N = the flange x axis made orthogonal to z_N (the flange y axis when x_F is within 1e-6 rad
/// of the axis), y_N = z_N x x_N. For axis_F = z_F this is a pure translation.
Eigen::Isometry3d CalcToolOffset(const NeedleConfig& config);

/// The immutable rigid needle: pose of the needle from the flange pose.
class RigidNeedleModel {
 public:
  /// Validates `config` (InputError).
  explicit RigidNeedleModel(const NeedleConfig& config);

  const NeedleConfig& get_config() const { return config_; }
  double length() const { return config_.length; }
  /// X_FN, see CalcToolOffset.
  const Eigen::Isometry3d& get_tool_offset() const { return X_FN_; }
  /// X_WN = X_WF X_FN.
  Eigen::Isometry3d CalcNeedlePose(const Eigen::Isometry3d& X_WF) const { return X_WF * X_FN_; }

 private:
  NeedleConfig config_;
  Eigen::Isometry3d X_FN_;
};

/// The moving part of a rigid needle over one step: its pose at the start and at the end of the
/// step (kinematic: prescribed by the robot), and the bevel roll. Cheap to copy.
struct RigidNeedleState {
  Eigen::Isometry3d X_WN_start = Eigen::Isometry3d::Identity();  ///< pose at step start
  Eigen::Isometry3d X_WN_end = Eigen::Isometry3d::Identity();    ///< pose at step end
  /// Rotation of the bevel about the needle axis z_N (rad), the steering degree of freedom.
  double bevel_angle = 0.0;

  /// Base position at step start / end (m).
  Eigen::Vector3d p_WBase_start() const { return X_WN_start.translation(); }
  Eigen::Vector3d p_WBase_end() const { return X_WN_end.translation(); }
};

/// Places the needle at the flange pose X_WF (start and end of the step equal): initialization.
void ResetRigidNeedle(const RigidNeedleModel& model, const Eigen::Isometry3d& X_WF,
                      RigidNeedleState& state);
/// Sets the end-of-step pose from the flange pose the robot reaches at the end of the step.
void SetRigidNeedleTarget(const RigidNeedleModel& model, const Eigen::Isometry3d& X_WF,
                          RigidNeedleState& state);
/// Ends the step: start pose = end pose.
void AdvanceRigidNeedle(RigidNeedleState& state);

/// Tip position p_WTip = X_WN (0, 0, L) (m) for a pose of the needle frame.
inline Eigen::Vector3d CalcTipPosition(const Eigen::Isometry3d& X_WN, double length) {
  return X_WN * Eigen::Vector3d(0.0, 0.0, length);
}

/// Rotation about z by `angle` (rad): R_z(angle).
Eigen::Matrix3d RotationZ(double angle);

/// Second moment of area of a solid circular section, I = pi r^4 / 4 (m^4).
double CalcSecondMomentOfArea(double radius);

}  // namespace nsim
