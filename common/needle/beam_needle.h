#pragma once
// The flexible needle (thesis §5.3): co-rotational Euler-Bernoulli beam elements with 6-DoF
// nodes (position, orientation), base node clamped to the flange pose (prescribed exactly),
// integrated with linearized implicit Euler like the tissue, and exposed to the constraint
// solver as a ConstraintBody (so W sums the needle's and the tissues' compliances, thesis
// eq. 3.2).
//
// Element e between nodes i = e and j = e + 1 (rest length L_e, straight at rest): the
// co-rotated element frame R_e = [x_e, y_e, z_e] has z_e along x_j - x_i and x_e the mean of
// the two nodes' x directors made orthogonal to z_e. In R_e the element's deformation is the
// elongation |x_j - x_i| - L_e and the nodal rotations theta_i = log(R_e^T R_i),
// theta_j = log(R_e^T R_j); the local force is K_loc d (the 12 x 12 Euler-Bernoulli stiffness,
// axis z, translations then rotations per node), rotated back: f = -T K_loc d with
// T = diag(R_e, R_e, R_e, R_e). The step's tangent is T K_loc T^T (the co-rotational
// approximation also used for the tissue) plus the geometric stiffness of the axial tension.
//
// One step (same convention as common/fem): A dv = b with dv = (dv_k, dw_k) per node,
//   A = (1 + h alpha) M + (h beta + h^2) K,  b = h f - h alpha M u - (h beta + h^2) K u,
// u = (v_k, w_k) (world linear and angular velocities), x+ = x + h v+, R+ = exp(h w+) R.
// M is lumped: rho A L per node (halves at the ends) and an isotropic rotational inertia
// rho (2 I) L (the polar moment; exact about the axis, 2x about the lateral axes: irrelevant
// for a quasi-static needle, where h^2 K dominates A). The base node's dv is prescribed from
// the target flange pose and eliminated; the block-tridiagonal A_ff is factorized by a block
// Cholesky (6 x 6 blocks, O(#nodes)).
//
// ConstraintBody view: 2 n "nodes". Node k < n is the position of beam node k (m; forces in
// N). Node n + k is the rotation of beam node k over the current step, a rotation vector
// (rad; start 0, free h w_free), and its "force" is a torque (N m): a row may act on
// orientations too. The compliance h^2 A^-1 acts on both.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "common/constraints/constraint_body.h"
#include "common/needle/rigid_needle.h"

namespace nsim {

/// The flexible needle of thesis §5.3 by default: 20 cm, radius 0.6 mm, E 5 GPa.
NeedleConfig MakeFlexibleNeedleConfig();

/// Beam discretization and time stepping of a flexible needle.
struct BeamNeedleConfig {
  NeedleConfig needle = MakeFlexibleNeedleConfig();
  int num_elements = 20;      ///< beam elements (-), >= 1; nodes = elements + 1
  double time_step = 0.02;    ///< h (s), > 0; use the tissue's step
  double rayleigh_mass = 0.0;       ///< alpha (1/s), >= 0
  double rayleigh_stiffness = 0.0;  ///< beta (s), >= 0
  /// Gravity (m/s^2); zero by default (a 2 g needle's weight is negligible against tissue forces).
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();

  /// Throws InputError "needle.<key> must be ..., got <value>".
  void Validate() const;
};

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// Immutable beam needle: geometry, section properties, lumped mass, local element stiffness.
class BeamNeedleModel {
 public:
  /// Validates `config` (InputError).
  explicit BeamNeedleModel(const BeamNeedleConfig& config);

  const BeamNeedleConfig& get_config() const { return config_; }
  int num_nodes() const { return config_.num_elements + 1; }
  int num_elements() const { return config_.num_elements; }
  double length() const { return config_.needle.length; }
  double element_length() const { return element_length_; }
  /// E I (N m^2) and E A (N) of the section.
  double bending_stiffness() const { return ei_; }
  double axial_stiffness() const { return ea_; }
  /// X_FN, see CalcToolOffset.
  const Eigen::Isometry3d& get_tool_offset() const { return X_FN_; }
  /// Element stiffness in the element frame (axis z), dofs (u_i, theta_i, u_j, theta_j).
  const Matrix12d& get_local_stiffness() const { return k_local_; }
  /// Lumped translational mass (kg) and rotational inertia (kg m^2) of node k.
  double node_mass(int k) const { return mass_[k]; }
  double node_inertia(int k) const { return inertia_[k]; }

 private:
  BeamNeedleConfig config_;
  double element_length_, ei_, ea_;
  Eigen::Isometry3d X_FN_;
  Matrix12d k_local_;
  std::vector<double> mass_, inertia_;
};

/// Mutable needle state. Cheap to copy (O(#nodes) small matrices).
struct BeamNeedleState {
  /// Straight needle at rest at the identity flange pose.
  explicit BeamNeedleState(const BeamNeedleModel& model);

  double time = 0.0;                ///< simulation time (s)
  Eigen::Matrix3Xd x;               ///< node positions (m), 3 x n, node 0 = base, n-1 = tip
  std::vector<Eigen::Matrix3d> R;   ///< node orientations R_WN_k (z = needle direction), n
  Eigen::Matrix3Xd v;               ///< linear velocities (m/s), 3 x n
  Eigen::Matrix3Xd w;               ///< angular velocities, world frame (rad/s), 3 x n
  Eigen::Matrix3Xd external_forces;   ///< nodal forces (N), 3 x n, held over the next step
  Eigen::Matrix3Xd external_torques;  ///< nodal torques (N m), 3 x n, held over the next step
  /// Pose the base node reaches at the end of the next step (X_WF X_FN).
  Eigen::Isometry3d X_WBase_target = Eigen::Isometry3d::Identity();
  /// Rotation of the bevel about the tip's needle axis (rad), the steering degree of freedom.
  double bevel_angle = 0.0;

  // written by the free motion (BeamNeedleBody::BeginStep)
  Eigen::Matrix3Xd x_free;    ///< free-motion positions (m), 3 x n
  Eigen::Matrix3Xd phi_free;  ///< free-motion rotation increments h w_free (rad), 3 x n
  Eigen::Matrix3Xd v_free;    ///< free-motion linear velocities (m/s)
  Eigen::Matrix3Xd w_free;    ///< free-motion angular velocities (rad/s)

  int num_nodes() const { return static_cast<int>(x.cols()); }
};

/// Puts the needle straight and at rest at the flange pose X_WF (and the base target there).
void ResetBeamNeedle(const BeamNeedleModel& model, const Eigen::Isometry3d& X_WF,
                     BeamNeedleState& state);
/// Sets the base pose of the end of the next step from the flange pose (InputError on NaN).
void SetBeamNeedleTarget(const BeamNeedleModel& model, const Eigen::Isometry3d& X_WF,
                         BeamNeedleState& state);

/// Internal elastic forces (N) and torques (N m) at the state's x and R, 3 x n each (zero for
/// rigid motions). For tests and diagnostics.
void CalcBeamElasticForces(const BeamNeedleModel& model, const BeamNeedleState& state,
                           Eigen::Matrix3Xd& forces, Eigen::Matrix3Xd& torques);

/// The needle as a constraint body. Step protocol as FemConstraintBody:
///   body.BeginStep();  ...rows on body points...;  solver (ApplyCorrection commits);
///   body.EndStep();    // commits the free motion when no correction came
class BeamNeedleBody : public ConstraintBody {
 public:
  /// model and state must outlive the body.
  BeamNeedleBody(const BeamNeedleModel& model, BeamNeedleState& state);

  /// Free motion: forces at the step start, A and b, block factorization, dv with the base
  /// prescribed; writes state.x_free, phi_free, v_free, w_free. New compliance version.
  void BeginStep();
  /// Commits the free motion unless ApplyCorrection already committed the step.
  void EndStep();
  bool in_step() const { return in_step_; }

  int num_nodes() const override { return 2 * n_; }
  const Eigen::Matrix3Xd& start_positions() const override { return start_; }
  const Eigen::Matrix3Xd& free_positions() const override { return free_; }
  void ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                       Eigen::MatrixXd& displacements) const override;
  std::uint64_t compliance_version() const override { return version_; }
  void ApplyCorrection(const Eigen::Matrix3Xd& dx) override;

  /// Orientation of the tip node after the free motion, exp(phi_free) R (z = needle direction).
  Eigen::Matrix3d CalcFreeTipFrame() const;

  /// Sensitivity of this step's free motion to the base target (after BeginStep): the free
  /// motion is A_ff dv_f = b_f - A_f0 dv_0 with A, b from the step start and
  /// dv_0 = [(p_target - x_0) / h - v_0; log(R_target R_0^T) / h - w_0], so it is affine in
  /// p_target and, to first order, in a rotation R_target' = exp(dtheta) R_target:
  ///   d free = S [dp; dtheta],  S = 3 (2n) x 6, the ConstraintBody's pseudo-node rows
  /// (positions of nodes 0..n-1 (m), then the rotation increments phi of nodes 0..n-1 (rad)),
  /// columns dp (m) then dtheta (rad), world axes. Column j: dv_0 = h^-1 [I; J_l^-1(phi_0)] e_j
  /// (J_l^-1 the inverse left Jacobian of SO(3) at phi_0 = log(R_target R_0^T): exact for the
  /// first order), the free nodes' -A_ff^-1 A_f0 dv_0 by the step's block Cholesky (6 reduced
  /// solves), times h. Exact for translations; rotations: O(|dtheta|^2).
  void CalcFreeMotionSensitivity(Eigen::MatrixXd& S) const;

  const BeamNeedleModel& model() const { return model_; }
  BeamNeedleState& state() { return state_; }
  const BeamNeedleState& state() const { return state_; }

 private:
  void Commit(const Eigen::Matrix3Xd* dx);
  // solves A_ff y = r in place over the free nodes (6 (n-1) entries)
  void SolveReduced(Eigen::VectorXd& r) const;

  const BeamNeedleModel& model_;
  BeamNeedleState& state_;
  int n_;
  double h_;
  bool in_step_ = false;
  std::uint64_t version_ = 0;
  Eigen::Matrix3Xd start_, free_;  // 3 x 2n views for the constraint solver
  // block-tridiagonal system over all nodes: diag_[k] = A(k,k), upper_[k] = A(k,k+1)
  std::vector<Matrix6d> diag_, upper_;
  // block Cholesky of A_ff (free nodes 1..n-1): factors of the Schur blocks and S^-1 U
  std::vector<Eigen::LLT<Matrix6d>> schur_;
  std::vector<Matrix6d> gain_;
  Eigen::VectorXd u_, f_, b_, dv_;                // 6n scratch
  mutable Eigen::VectorXd rhs_;                   // 6 (n-1) scratch
};

}  // namespace nsim
