#pragma once
// The inverse-simulation controller (thesis §3.3, appendix A): one control step
//   1. steps the registered liver model (SteeringSimulation) with the markers and the measured
//      flange pose;
//   2. picks the insertion phase (fig. 3.3) and the active objectives e_p, e_a, e_e
//      (eq. 3.3-3.5) and advances the path target;
//   3. the Jacobian by central differences over 12 flange-pose perturbations (eq. 3.6) or 14
//      iiwa joint perturbations (eq. A.2), each a constraint-space solve of the frozen step;
//   4. the Tikhonov inverse (eq. 3.7-3.8) and the gain law (eq. 3.9 / A.3) give the target.
//
// e_e in the model: the skin is not simulated here (thesis fig. 3.2: the entry point is
// measured). The stored puncture point p_p and plane come from the first punctured EntryPoint;
// the current point p_c is the measured one, and under a perturbation it moves rigidly with the
// needle (the skin point stays on the needle), which makes e_e controllable. In a scene without
// skin, the liver entry point plays that role (config.liver_entry_objective).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <vector>

#include "common/control/objectives.h"
#include "common/core/samples.h"
#include "common/mesh/tet_mesh.h"
#include "common/robot/iiwa14.h"
#include "common/robot/iiwa14_ik.h"
#include "common/steering/steering_config.h"
#include "common/steering/steering_simulation.h"

namespace nsim {

/// Inputs of one control step.
struct SteeringInput {
  std::vector<Eigen::Vector3d>
      p_WM;  ///< marker positions to register to (m): measured or predicted
  Eigen::Isometry3d X_WE = Eigen::Isometry3d::Identity();  ///< measured flange pose
  Vector7d q = Vector7d::Zero();  ///< measured joints (rad), used with SteeringDof::kJoint7
  EntryPoint entry;               ///< the localized skin entry point (punctured = false: none)
  /// The bevel's roll about the needle axis (rad, SensorFrame::bevel_angle): the model's bevel
  /// load (InverseModelConfig::bevel) acts in this orientation.
  double bevel_angle = 0.0;
  /// The controller's last command, which the robot may not have carried out yet: the targets
  /// in flight over the loop's latency. When given (and control.compensate_in_flight), the step
  /// is computed for the objectives expected once that command has taken effect,
  /// e + J (commanded - measured), and added to the command instead of to the measured pose
  /// (a Smith-predictor form of eq. 3.9 / A.3, README "Control under latency"). X_WE_commanded
  /// for kCartesian6, q_commanded for kJoint7.
  std::optional<Eigen::Isometry3d> X_WE_commanded;
  std::optional<Vector7d> q_commanded;
  /// The loop's measured latency d in frames (a frame's answer is executed in the step of
  /// frame + d; ControllerLoop measures it from applied_seq), 0 when not known yet. It caps the
  /// gain of the liver's load rows (kLoadGainMargin).
  int latency_steps = 0;
  /// The loop holds the robot this step (ControllerLoop's preparation phase): the model step,
  /// the phase, the path index and e only; no Jacobian and no law (the target is the measured
  /// pose). Nothing of the skipped work changes the controller's state.
  bool hold = false;
};

/// The gain margin of e_l's rows: their gain is at most the stable limit of a loop that acts
/// on d-frame-old errors without compensating the commands in flight
/// (common/control/delay_margin.h) over this factor (6 dB). The in-flight compensation assumes
/// the model predicts what a needle motion does to e_l, which it does worst of all objectives
/// (the patient's liver follows the needle through the markers the frozen step holds still;
/// the patient's friction); at 1 and 3 frames the cap (0.5, 0.22) is above the default gain.
inline constexpr double kLoadGainMargin = 2.0;

/// Wall-clock cost of one control step (s).
struct SteeringTimings {
  double simulation = 0.0;  ///< model step (free motion, registration, needle, commit)
  double jacobian = 0.0;    ///< 12 or 14 perturbation solves + assembly
  double control = 0.0;     ///< Tikhonov inverse and law
  double total = 0.0;
};

/// Result of one control step.
struct SteeringOutput {
  /// false: non-finite objectives or Jacobian, or a constraint solve of the step (the model
  /// step, the frozen-step solves of e and of the Jacobian) did not converge; hold the robot
  bool valid = false;
  InsertionPhase phase = InsertionPhase::kBeforeSkin;
  int path_index = 0;        ///< current path target
  bool reached_end = false;  ///< the last path target is the current one
  Eigen::VectorXd e;         ///< objectives of the phase (eq. 3.3-3.5 stacked)
  /// the objectives expected once the commands in flight have taken effect (= e without them)
  Eigen::VectorXd e_expected;
  Eigen::MatrixXd J;         ///< rows x 6 or rows x 7
  Eigen::Isometry3d X_WE_target = Eigen::Isometry3d::Identity();  ///< eq. 3.9 (kCartesian6)
  Vector7d q_target = Vector7d::Zero();                           ///< eq. A.3 (kJoint7)
  bool step_limited = false;
  /// the gain of e_l's rows this step (control.gains.load capped for input.latency_steps;
  /// 0 without them)
  double load_gain = 0.0;
  /// the target was turned back onto control.max_needle_tilt (common/control/needle_tilt.h)
  bool tilt_limited = false;
  /// the target was moved back onto control.max_insertion_step or, in the last free stretch
  /// before the target, control.free_stretch_step (common/control/insertion_step.h)
  bool insertion_limited = false;
  Eigen::Vector3d p_WTip = Eigen::Vector3d::Zero();     ///< model tip (m)
  Eigen::Vector3d p_WTarget = Eigen::Vector3d::Zero();  ///< model's current path target (m)
  Eigen::Vector3d p_WFinal = Eigen::Vector3d::Zero();   ///< model's final target (m)
  int num_perturbations = 0;
  /// kJoint7: the joint-limit avoidance step added in the arm's self-motion (rad)
  Vector7d null_space_step = Vector7d::Zero();
  int num_unconverged_solves = 0;  ///< constraint solves of this step that did not converge
  SteeringStepReport model;
  SteeringTimings timings;
};

class SteeringController {
 public:
  /// Validates the configs (InputError) and builds the model with the needle at X_WE0.
  SteeringController(const InverseModelConfig& model, const SteeringPathConfig& path,
                     const SteeringControlConfig& control, const TetMesh& mesh,
                     const Eigen::Isometry3d& X_WE0);
  ~SteeringController();
  // flange_ik_ refers to iiwa_: neither copied nor moved
  SteeringController(const SteeringController&) = delete;
  SteeringController& operator=(const SteeringController&) = delete;

  /// Before the first Update, for a controller that starts while the needle may already be in
  /// (SteeringSimulation::CatchUp): the model's needle is driven in to the measured flange pose
  /// (input.X_WE, or the pose of input.q for kJoint7) with the markers at input.p_WM. The path
  /// index and the phase need no catch-up: the first Update advances the index past every path
  /// target the tip has passed, and takes the phase from input.entry and the model's liver; the
  /// entry plane of e_e is the first measured entry point it sees (the current one, not the
  /// one at the skin's puncture, which a frame does not carry).
  CatchUpReport CatchUp(const SteeringInput& input, const CatchUpConfig& config = {});

  /// One control step (see the file comment). InputError on malformed input (marker count,
  /// non-finite values).
  SteeringOutput Update(const SteeringInput& input);

  /// The objective vector of `phase` at flange pose X_WF for the current step (no side
  /// effects): the function the Jacobian differentiates.
  Eigen::VectorXd EvaluateObjectives(const Eigen::Isometry3d& X_WF, InsertionPhase phase) const;

  /// Flange pose of the iiwa at q (X_WB X_BF(q)).
  Eigen::Isometry3d CalcFlangePose(const Vector7d& q) const;

  const SteeringSimulation& simulation() const { return *sim_; }
  const SteeringControlConfig& config() const { return control_; }
  const Iiwa14Model& iiwa() const { return iiwa_; }

 private:
  /// -null_space_gain (q - q_mid) projected into the null space of the needle's motion at q
  /// (the arm's self-motion and, without a bevel in the model, the roll about the needle's own
  /// axis: no point of the needle moves), capped at the law's max_joint_step, plus the Newton
  /// correction of the needle's second-order motion.
  Vector7d CalcNullSpaceStep(const Vector7d& q) const;
  /// The rows that map a flange twist [v_F; w] (W, v_F at the flange origin) to the needle's
  /// motion: its base point's velocity and its angular velocity, or (roll_free_) only the two
  /// components of it across the needle's axis.
  Eigen::MatrixXd CalcNeedleMotionRows(const Eigen::Isometry3d& X_WF) const;
  /// The joint step dq from q scaled down (direction kept) so that the flange moves at most
  /// control.law.max_translation_step and turns at most max_rotation_step to first order;
  /// *limited tells whether it was.
  Vector7d LimitFlangeMotion(const Vector7d& q, const Vector7d& dq, bool* limited) const;
  /// The tip the path switching compares with the path points (SteeringPathConfig::advance):
  /// p_WTip, the model's tip at the measured flange pose X_WF, or that tip moved rigidly to
  /// the last commanded pose.
  Eigen::Vector3d CalcSwitchingTip(const SteeringInput& input, const Eigen::Isometry3d& X_WF,
                                   const Eigen::Vector3d& p_WTip) const;
  /// The map of e_l for the step (load_map_) from the frozen step's stiffness.
  void UpdateLoadMap();
  /// The point the tilt bound turns the needle about (control.max_needle_tilt): the current
  /// entry point once known, else the flange's origin (outside the body).
  Eigen::Vector3d TiltPivot(const Eigen::Isometry3d& X_WF) const;
  /// Once the liver is punctured, moves *X_WF_target back so that the needle advances at most
  /// control.max_insertion_step from X_WF_base, the pose the step starts from (the measured one
  /// plus the commands in flight), and at most control.free_stretch_step in the last free
  /// stretch before the final target p_WFinal (the model's tip p_WTip); returns whether it did.
  bool LimitAdvance(InsertionPhase phase, const Eigen::Isometry3d& X_WF_base,
                    const Eigen::Vector3d& p_WTip, const Eigen::Vector3d& p_WFinal,
                    Eigen::Isometry3d* X_WF_target) const;
  /// q clamped into the iiwa's limits shrunk by control.joint_limit_margin.
  Vector7d ClampWithMargin(const Vector7d& q) const;
  /// The objective vector of `phase` from one evaluation of the frozen step.
  Eigen::VectorXd CalcObjectives(const SteeringEvaluation& eval, InsertionPhase phase) const;

  SteeringControlConfig control_;
  Iiwa14Model iiwa_;
  // the joints of a flange pose turned back onto the tilt bound: the iiwa's IK from the law's
  // joints, one descent (no restarts on other branches), no pull toward mid-range
  Iiwa14InverseKinematics flange_ik_;
  std::unique_ptr<SteeringSimulation> sim_;
  int path_index_ = 0;
  double switch_distance_ = 0.0;  // (m)
  PathAdvance advance_ = PathAdvance::kMeasured;
  bool entry_known_ = false;
  SkinPlane entry_plane_;
  Eigen::Vector3d p_WC_ = Eigen::Vector3d::Zero();  // current entry point (m)
  Eigen::Isometry3d X_WN_step_ = Eigen::Isometry3d::Identity();
  mutable SnapshotWorkspace workspace_;
  // the needle on the flange, for the null-space step
  Eigen::Vector3d needle_p_FBase_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d needle_axis_F_ = Eigen::Vector3d::UnitZ();
  bool roll_free_ = true;  // no bevel in the model: the needle's roll is free
  bool align_in_liver_ = false;  // e_a on the base's direction in the liver (liver_alignment)
  bool liver_load_ = false;      // e_l in the liver (liver_load, rigid model needle)
  // e_l = load_map_ F, fixed for a step: K_t^-1 [t_1 t_2]^T (m/N), zero without a stiffness
  Eigen::Matrix<double, 2, 3> load_map_ = Eigen::Matrix<double, 2, 3>::Zero();
};

/// The iiwa model used by the controller: control.iiwa with the tool at the flange.
Iiwa14Config MakeFlangeIiwaConfig(const Iiwa14Config& iiwa);

}  // namespace nsim
