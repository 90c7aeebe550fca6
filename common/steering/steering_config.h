#pragma once
// Configuration of the inverse simulation (thesis §3.2-3.3, appendix A): the liver model the
// controller registers to the markers, its needle, the planned path, and the control settings.
// Plain structs with defaults, SI units, world frame W (the liver mesh frame); the inverse
// side's scenario loader fills them from the `inverse:` and `controller:` sections.

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "common/control/control_law.h"
#include "common/control/objectives.h"
#include "common/control/path_targets.h"
#include "common/fem/fem_config.h"
#include "common/mesh/oriented_box.h"
#include "common/needle/beam_needle.h"
#include "common/needle/bevel_tip.h"
#include "common/needle/needle_tissue.h"
#include "common/needle/rigid_needle.h"
#include "common/robot/iiwa14.h"
#include "common/robot/pose_math.h"

namespace nsim {

/// Which degrees of freedom the Jacobian is taken over (thesis eq. 3.6 vs A.2).
enum class SteeringDof {
  kCartesian6,  ///< 12 pose perturbations of the flange, Cartesian targets (eq. 3.6, 3.9)
  kJoint7,      ///< 14 joint perturbations of the iiwa, joint targets (eq. A.2, A.3)
};
/// "cartesian6" / "joint7"; InputError naming `key` otherwise.
SteeringDof ParseSteeringDof(const std::string& text, const std::string& key);
const char* ToString(SteeringDof dof);

/// The model's needle: kinematic on the flange, or a beam clamped to it (YAML inverse.needle).
enum class ModelNeedleKind { kRigid, kFlexible };

/// The liver model of the inverse simulation: its own mesh and material, registered to the
/// fiducial markers by bilateral constraints, with a rigid or flexible needle inside.
struct InverseModelConfig {
  /// Material, damping and solver of the inverse liver. young_modulus is the nominal (believed)
  /// value; the model uses young_modulus * young_modulus_factor.
  FemConfig liver = [] {
    FemConfig c;
    c.gravity = Eigen::Vector3d::Zero();
    c.rayleigh_mass = 0.1;
    c.rayleigh_stiffness = 0.01;
    return c;
  }();
  /// Factor on the nominal Young's modulus (-), > 0: the model's stiffness error (thesis §5.1
  /// setup; Baksic: +-13 %).
  double young_modulus_factor = 1.0;
  /// Rest positions of the fiducial markers in the liver (m), >= 1, each inside the mesh.
  std::vector<Eigen::Vector3d> markers_W;
  /// The needle on the flange (geometry, tool offset; the shared scenario's).
  NeedleConfig needle;
  /// kRigid (default): the needle is kinematic, at the flange pose. kFlexible: a co-rotational
  /// beam (common/needle/beam_needle.h) whose base is clamped to the flange pose, a second
  /// compliant body in the model's constraint problem, as the patient's flexible needle.
  ModelNeedleKind needle_kind = ModelNeedleKind::kRigid;
  /// kFlexible: the beam's material and discretization (YAML inverse.needle: {type: flexible,
  /// young_modulus, poisson_ratio, density, elements, rayleigh_mass, rayleigh_stiffness}, the
  /// keys of the patient's needle section). Its geometry is `needle`'s and its time step the
  /// liver's: CalcModelBeamConfig.
  BeamNeedleConfig flexible;
  /// The needle-liver coupling of the model: the patient's law (common/needle/needle_tissue.h)
  /// with the model's own values (YAML inverse.<key>, the keys of the patient's
  /// needle.<tissue>: puncture_force, point_spacing, tip_constraint, tip_hold, seed_distance,
  /// lateral_compliance, tip_compliance, friction_coefficient, friction_force_per_length,
  /// contact_margin). By default a 0.3 N puncture and no friction (friction_coefficient 0:
  /// every row bilateral or a contact); with friction, an axial friction row per trajectory
  /// point, with the model's own normal forces.
  TissueCouplingConfig coupling = [] {
    TissueCouplingConfig c;
    c.name = "liver";
    c.puncture_force = 0.3;
    c.friction_coefficient = 0.0;
    return c;
  }();
  /// With friction: the Jacobian's frozen step holds the friction rows at the step's forces (a
  /// sliding needle, ConstraintSnapshot::set_hold_friction; YAML inverse.jacobian_friction:
  /// held) instead of solving their law again (solved), under which a small perturbation
  /// sticks and drags the model tissue: the Jacobian then hardly sees the needle advance.
  bool jacobian_friction_held = true;
  /// Regions of the model liver held fixed (YAML inverse.anchors, boxes in the world frame):
  /// where the organ is attached, as the planning images show it. Empty: the model is held by
  /// the markers alone. Every box must enclose a model node, and no marker may lie in one.
  std::vector<OrientedBox> anchors;
  /// The compliance of the registration and needle constraints, YAML
  /// inverse.constraint_compliance: true = rest (FemInverse::kRestFactor: h^2 A_0^-1,
  /// constant, so the columns of the markers and of every laid needle point are solved once and
  /// the model's factor may be refreshed in the background), false = last_factor
  /// (FemInverse::kReferenceFactor: the liver's last factorization; with linear_solver direct,
  /// this step's exact system, every column solved again each step). See
  /// SelectConstraintCompliance in common/fem/fem_solver.h.
  bool rest_compliance = false;
  /// The model needle's bevel tip (YAML inverse.bevel, the keys of the patient's needle.bevel;
  /// `inverse.bevel: patient` copies the patient's). Enabled: while the tip is in the model
  /// liver, the Misra tip load (common/needle/bevel_tip.h) acts as the patient's does
  /// (PatientScene::Step): for the rigid needle the tissue at the tip takes -Q y_B as nodal
  /// forces, held over the step and computed from the state at its start. Disabled (default):
  /// a symmetric tip, the model as without the option.
  BevelConfig bevel;

  /// Throws InputError "inverse.<key> must be ..., got ..." for the first invalid field.
  void Validate() const;
};

/// The beam of a kFlexible model needle: config.flexible with config.needle's geometry (length,
/// radius, tool offset, axis) and config.liver's time step.
BeamNeedleConfig CalcModelBeamConfig(const InverseModelConfig& config);

/// Which tip position moves the path target on (SteeringPathConfig::advance).
enum class PathAdvance {
  kMeasured,   ///< the model's tip at the measured pose
  kCommanded,  ///< the tip where the last command puts it (the commands in flight done)
};

/// The planned insertion: a straight line from a start point before the entry to the target.
struct SteeringPathConfig {
  Eigen::Vector3d entry_W = Eigen::Vector3d::Zero();   ///< planned skin entry (m)
  Eigen::Vector3d target_W = Eigen::Vector3d::Zero();  ///< target at rest, inside the liver (m)
  double approach_distance = 0.01;  ///< the tip starts this far before the entry (m), >= 0
  double spacing = 0.01;            ///< distance between consecutive path targets (m), > 0
  PathTargetConfig switching;       ///< when the tip counts as at a path point
  /// Whose tip the switching compares with the path points. kCommanded: the model's tip moved
  /// rigidly with the needle from the measured pose to the last commanded one (what the commands
  /// in flight will have done), so that the target runs as far ahead of the command as
  /// switching asks whatever the latency; kMeasured: the tip at the measured pose, which lags
  /// the command by the loop's latency (the insertion then slows with it: v = k D / (1 + k d)).
  /// Without a command in flight (compensate_in_flight off, the first frames) both are the same.
  /// (YAML controller.path.advance: commanded | measured)
  PathAdvance advance = PathAdvance::kCommanded;

  /// Throws InputError "controller.path.<key> ...".
  void Validate() const;
};

/// Which needle direction the alignment objective e_a (eq. 3.4) compares with the planned one.
/// The same for a rigid needle; they differ for a flexible one, bent in the tissue.
enum class AlignmentReference {
  kTip,   ///< the direction at the tip (the bent needle's)
  kBase,  ///< the direction at the base (the flange's needle axis)
};

/// Whether e_a stays an objective in the liver (phase 3), on the needle's base direction.
enum class LiverAlignment {
  kAuto,  ///< for a flexible model needle (kBase), not for a rigid one (kNone)
  kNone,  ///< the thesis's phases: e_p and e_e only in the liver
  kBase,  ///< e_a on the base's direction (the flange's needle axis) in the liver too
};

/// Jacobian, inverse and law settings.
struct SteeringControlConfig {
  SteeringDof dof = SteeringDof::kCartesian6;
  /// Perturbation steps of eq. 3.6: [translation (m) x 3, rotation (rad) x 3], each > 0.
  Vector6d pose_steps = (Vector6d() << 1e-3, 1e-3, 1e-3, 5e-3, 5e-3, 5e-3).finished();
  /// Perturbation steps of eq. A.2 per joint (rad), each > 0.
  Vector7d joint_steps = Vector7d::Constant(2e-3);
  ObjectiveGains gains;  ///< k of eq. 3.9 / A.3
  /// r of eq. 3.7-3.8, step caps, frame of the pose increments. r = 1e-4 (units of J^T J: m^2
  /// per m^2 or per rad^2): in the liver the needle drags the tissue laterally, so the lateral
  /// columns of e_p have singular values of a few 1e-3; their exact inverse (r = 1e-6) turns
  /// millimetre errors into 0.25 rad joint steps and the joint loop oscillates, r = 1e-3 damps
  /// them so much that a 1 mm lateral error stays (measured on liver_700, static liver:
  /// final errors 0.012 mm Cartesian and 0.016-0.028 mm joint with r = 1e-4).
  ControlLawConfig law = [] {
    ControlLawConfig c;
    c.regularization = 1e-4;
    return c;
  }();

  /// e_a's needle direction (YAML controller.alignment: tip | base). With a flexible model
  /// needle held laterally at its tip by the tissue, a lateral flange motion hardly moves the
  /// tip (its e_p column is a few % of the rigid needle's) but turns the tip's direction
  /// (~10 rad/m): aligning the tip's direction then asks for large lateral motions that bend
  /// the needle; aligning the base keeps e_a's rows those of a rigid needle (README, flexible
  /// model needle).
  AlignmentReference alignment = AlignmentReference::kTip;
  /// e_a in the liver (YAML controller.liver_alignment: auto | none | base). e_p and e_e fix a
  /// rigid needle's direction there (the line through the entry point and the tip: kNone, the
  /// thesis's phases); a flexible needle held by the tissue leaves its base free to turn about
  /// the entry point with hardly any effect on the tip, and without an objective for it the
  /// base turned 55-63 degrees by the end of a run. kBase keeps e_a (on the base's direction,
  /// whatever `alignment` says: the tip's direction is the bent needle's) in the liver; kAuto
  /// (the default) chooses kBase for a flexible model needle, kNone for a rigid one.
  LiverAlignment liver_alignment = LiverAlignment::kAuto;
  /// The weight w of e_l in the liver (YAML controller.liver_load, >= 0; 0: off, the thesis's
  /// objectives): the liver's lateral force on a rigid model needle, as the lateral needle
  /// displacement that would remove it, times w, is an objective too (objectives.h). In the
  /// liver the tissue holds the tip, so a lateral needle motion moves tip and target together
  /// (e_p's lateral singular values are a few 1e-3): e_p and e_e leave the needle free to drag
  /// the liver, and the law's steps toward a lateral e_p did, by up to 10 mm across the
  /// breathing (README "Control under latency"). With w well above those singular values and
  /// well below 1, e_l decides only the directions e_p barely sees. No effect for a flexible
  /// model needle (its load is not computed).
  double liver_load = 0.0;
  /// Include e_e (eq. 3.5) in phase 3 even when the skin entry is unknown, using the liver
  /// entry point (scenes without a skin).
  bool liver_entry_objective = true;
  /// Account for the commands in flight (SteeringInput::X_WE_commanded / q_commanded): the
  /// loop's nominal poles are then 1 - k whatever the latency (README "Control under
  /// latency"); false: eq. 3.9 / A.3 from the measured pose, whose poles move with the latency.
  bool compensate_in_flight = true;
  /// The iiwa (base pose, limits) for kJoint7.
  Iiwa14Config iiwa;
  /// kJoint7: the redundancy's use. The iiwa's seventh joint leaves the flange a one-dimensional
  /// self-motion (the null space of the flange Jacobian); each step adds -null_space_gain
  /// (q - q_mid) projected on it, so the joints drift toward mid-range without moving the flange
  /// or the needle (Liegeois' joint-limit avoidance; the step's second-order flange motion is
  /// taken back by one Newton step). The law's own step moves the flange at most
  /// law.max_translation_step and max_rotation_step, as the Cartesian law's does. 0: the
  /// minimum-norm step only. (1/step, in [0, 1])
  double null_space_gain = 0.02;
  /// The bound on the commanded needle's tilt (rad, in (0, pi]): the angle between its axis and
  /// the planned insertion direction (common/control/needle_tilt.h). A target tilted more is
  /// turned back onto the bound about the needle's entry point (kJoint7: the joints follow by
  /// Newton steps on the flange pose). In the liver e_p and e_e do not fix a flexible needle's
  /// direction, and without it its base turned 55-63 degrees inside the liver; the rigid needle
  /// uses up to 19 degrees to follow the breathing (README "Flexible and bevelled needles").
  /// pi (the default): no bound. (YAML controller.max_needle_tilt)
  double max_needle_tilt = M_PI;
  /// The needle's advance along its own axis per control step, once the liver is punctured
  /// (m, >= 0): a target that would advance the needle further is moved back along its axis
  /// (common/control/insertion_step.h; kJoint7: the joints follow by Newton steps on the flange
  /// pose). Retraction and the motion across the needle are not bounded; nor is the way from
  /// the skin to the liver, which the breathing moves beneath the tip. 0 (the default): no
  /// bound beyond law.max_translation_step. (YAML controller.max_insertion_step)
  double max_insertion_step = 0.0;
  /// The last free stretch before the target, planned. The needle can be moved across its
  /// tissue only in the first quarter spacing past each trajectory point (the coupling's free
  /// stretch, NeedleTissueCoupling::CalcTipStretch); beyond it the tip is held and only
  /// advances along its axis. While the model's tip is in a free stretch from which it would
  /// reach the final target held, over more than a stretch's length and with no point seeded
  /// on the way (or one seeded within half a stretch's length before the target, whose hold
  /// would tie the target's tissue to the needle line), and the target is more than
  /// free_stretch_tolerance (m, >= 0) off the needle's axis, the needle's advance per step is
  /// bounded by free_stretch_step (m, >= 0; 0: off), so that the lateral error is corrected before
  /// the hold engages instead of being carried to the target (README "Where the target falls
  /// between the trajectory points"). A target at most a stretch's length past the end of one (the
  /// default scenario's) is not affected. (YAML controller.free_stretch_step,
  /// controller.free_stretch_tolerance)
  double free_stretch_step = 0.0002;
  double free_stretch_tolerance = 1e-4;
  /// kJoint7: the commanded joints stay this far inside the iiwa's position limits (rad), >= 0.
  double joint_limit_margin = 0.05;

  /// Throws InputError "controller.<key> ...".
  void Validate() const;
};

}  // namespace nsim
