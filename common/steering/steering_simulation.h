#pragma once
// The inverse simulation's liver model (thesis §3.2, fig. 3.2): a co-rotational FEM liver with
// its own mesh and Young's modulus, registered to the measured (or predicted) fiducial markers
// by bilateral constraints (marker material point == marker position, 3 rows each), a rigid
// needle placed at the measured flange pose with its own insertion state in the liver
// (common/needle: contact, puncture, entry / trajectory / tip points; frictionless, so every
// row is bilateral or a contact), and the planned path's targets as liver material points.
//
// Each Step is one implicit step: markers and needle move to their new positions over the step,
// free motion, constraint solve, commit. Before committing, the step's constraint problem is
// frozen in a ConstraintSnapshot, so that EvaluateAt(X_WF') answers "where would the needle
// tip, the path targets and the entry point be at the end of this step had the flange been at
// X_WF'" by a constraint-space solve only, without touching the state (thesis eq. 3.6 / A.2;
// DESIGN.md "Speed"). EvaluateAt(X_WF) reproduces the committed step.
//
// The needle (config.needle_kind): kinematic at the flange pose (rigid), or a co-rotational beam
// whose base is clamped to the flange pose (flexible, common/needle/beam_needle.h), a second
// compliant body of the step's constraint problem, with the patient's step protocol
// (PatientScene::Step): base target, bevel load on the tip node, free motion of both bodies,
// the coupling's rows on the beam's body points, one solve, commit. Its frozen step captures
// both bodies and the beam's free-motion sensitivity to the base pose (constraint_snapshot.h:
// exact for translations when the beam's free shape translates with its base, first order for
// rotations; the rows on the beam turn with the base); EvaluateAt then reports the bent
// needle's corrected tip and tip frame.
//
// A model built while the needle is already in (a controller started, or restarted, in the
// middle of an insertion) catches up with CatchUp before its first Step. The tissue's state
// around the needle depends on where the needle entered it and how it moved since, which no
// single frame shows (on liver_test_coarse, 5 s into the insertion, a needle driven in straight
// along its measured axis left the model's target 5.5 mm from where the model that followed the
// insertion has it). CatchUp assumes what a controlled insertion does: the needle went in along
// the planned path in the tissue. It brings the markers to their measured positions, drives the
// needle in along the path as the registered liver carries it, to the measured tip's depth (the
// coupling punctures the model liver and seeds its entry and trajectory points at the path's
// material points), then moves it, the tissue on it following, to the measured pose.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <utility>
#include <vector>

#include "common/constraints/constraint_set.h"
#include "common/constraints/constraint_solver.h"
#include "common/constraints/fem_body.h"
#include "common/fem/fem_model.h"
#include "common/fem/fem_solver.h"
#include "common/fem/fem_state.h"
#include "common/mesh/tet_mesh.h"
#include "common/mesh/tet_point.h"
#include "common/needle/beam_needle.h"
#include "common/needle/needle_tissue.h"
#include "common/needle/rigid_needle.h"
#include "common/steering/constraint_snapshot.h"
#include "common/steering/steering_config.h"

namespace nsim {

/// A path target as a liver material point plus a rest offset (for path points outside the
/// liver: they follow the first path point inside it).
struct PathPoint {
  TetPoint reference;  ///< liver material point
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< p = x(reference) + offset (m)
};

/// What the model predicts at the end of the current step for one flange pose.
struct SteeringEvaluation {
  Eigen::Isometry3d X_WN = Eigen::Isometry3d::Identity();  ///< needle pose (base frame N)
  Eigen::Vector3d p_WTip = Eigen::Vector3d::Zero();        ///< needle tip (m)
  /// Tip frame (z = the needle's direction at the tip): X_WN's rotation for the rigid needle,
  /// the beam's tip node for the flexible one.
  Eigen::Matrix3d R_WTip = Eigen::Matrix3d::Identity();
  std::vector<Eigen::Vector3d> p_WPath;                    ///< every path target (m)
  /// The tissue's constraint force on a rigid needle (world, N): the resultant over its
  /// points (ConstraintSnapshot's needle_force); zero for a flexible needle or no snapshot.
  Eigen::Vector3d needle_force = Eigen::Vector3d::Zero();
  ConstraintSolveReport solve;
};

/// How CatchUp drives the needle in.
struct CatchUpConfig {
  /// Needle advance per model step while it is driven in (m), > 0. 1 mm, the robot's own
  /// limit per control step: vs an insertion of 0.2 mm per step to 50 mm in a static liver
  /// (tests/steering/steering_simulation_test.cpp) the nodes differ by 0.02-0.04 mm after it
  /// (0.2 mm steps: < 0.001 mm, 5 times the cost; 2 mm steps: 0.13 mm and one trajectory point
  /// fewer).
  double advance_per_step = 1e-3;
  /// Steps over which the markers go from their rest positions to the measured ones, >= 1.
  int register_steps = 10;
  /// Largest turn of the needle per model step when it is moved from the path to the measured
  /// pose (rad), > 0: the robot's own limit per control step.
  double rotation_per_step = 0.01;
  /// Steps at the final pose, markers and needle held, for the tissue to settle, >= 0.
  int settle_steps = 10;
  /// No catch-up when the tip is at most this far past the path's start along the needle (m).
  double min_depth = 1e-4;

  /// Throws InputError "catch_up.<key> ...".
  void Validate() const;
};

/// What CatchUp did.
struct CatchUpReport {
  bool done = false;           ///< the needle was driven in (false: it was not in, nothing done)
  double depth = 0.0;          ///< how far the tip was driven in along the path (m)
  double aligned = 0.0;        ///< how far the tip then moved to its measured position (m)
  double aligned_angle = 0.0;  ///< and how far the needle turned (rad)
  int steps = 0;               ///< model steps taken
  TissuePhase liver_phase = TissuePhase::kOutside;  ///< after the catch-up
  int liver_points = 0;    ///< the liver's entry, trajectory and exit points after it
  double wall_time = 0.0;  ///< (s)
};

/// What one Step did.
struct SteeringStepReport {
  double time = 0.0;  ///< model time at the end of the step (s)
  FemStepStats fem;
  ConstraintSolveReport solve;
  int num_rows = 0;
  TissuePhase liver_phase = TissuePhase::kOutside;
  bool bevel_active = false;  ///< a bevel load acted over the step
};

/// The controller's liver: `mesh` with config.liver's material, E scaled by
/// young_modulus_factor, and the nodes inside inverse.anchors fixed (InputError for a box that
/// holds no node or a marker). Config must be valid.
std::unique_ptr<FemModel> MakeModelLiver(const InverseModelConfig& config, const TetMesh& mesh);

class SteeringSimulation {
 public:
  /// Builds the model (InputError: bad config, a marker or the target outside the mesh).
  /// The needle starts at the flange pose X_WF, outside the liver.
  SteeringSimulation(const InverseModelConfig& config, const SteeringPathConfig& path,
                     const TetMesh& mesh, const Eigen::Isometry3d& X_WF);
  ~SteeringSimulation();
  SteeringSimulation(const SteeringSimulation&) = delete;
  SteeringSimulation& operator=(const SteeringSimulation&) = delete;

  /// One step: the markers reach p_WM (m, one per configured marker) and the flange X_WF at
  /// the end of the step; bevel_angle (rad) is the bevel's roll about the needle axis (used
  /// with config.bevel enabled). InputError on a wrong marker count or non-finite input.
  ///
  /// Bevel (config.bevel.enabled, the tip in the liver): the load of this step is computed from
  /// the state at its start and held over it (PatientScene::Step); for the rigid needle the
  /// liver at the tip takes -Q y_B as nodal external forces, for the flexible one the beam's
  /// tip node takes Misra's load (config.bevel.mode: the torque M x_B by default). The load is
  /// part of the free motion, so the frozen step (EvaluateAt) keeps it fixed under every
  /// perturbation: the bevel's load follows the committed state, not the perturbed pose (it
  /// changes only with the roll, the tip frame and the tip's tissue point, which move little
  /// within one step).
  SteeringStepReport Step(const std::vector<Eigen::Vector3d>& p_WM, const Eigen::Isometry3d& X_WF,
                          double bevel_angle = 0.0);

  /// Before the first Step, for a needle that may already be in (see the file comment): when
  /// the tip of the needle at X_WF is more than config.min_depth past the path's start along
  /// the needle's axis, the needle is parked before the path, the markers are moved to p_WM
  /// over config.register_steps, the needle is driven in along the registered path by
  /// config.advance_per_step per step, moved to X_WF by at most advance_per_step and
  /// rotation_per_step per step, and held for config.settle_steps, the markers at p_WM
  /// throughout; otherwise the needle is put at X_WF and nothing else is done (a needle that
  /// starts outside: the model is as built). InputError on a wrong marker count or non-finite
  /// input; std::logic_error after a Step. bevel_angle: the bevel roll of every catch-up step
  /// (rad, see Step).
  CatchUpReport CatchUp(const std::vector<Eigen::Vector3d>& p_WM, const Eigen::Isometry3d& X_WF,
                        const CatchUpConfig& config = {}, double bevel_angle = 0.0);

  /// The end of the last step re-solved with the flange at X_WF (constraint-space solve on the
  /// frozen step; no side effects). Before the first Step: kinematic only (rest tissue).
  SteeringEvaluation EvaluateAt(const Eigen::Isometry3d& X_WF, SnapshotWorkspace& workspace) const;
  /// The frozen step's stiffness against a translation of the rigid needle (N/m; ConstraintSnapshot::
  /// CalcNeedleTranslationStiffness); zero for a flexible needle or before the first step.
  Eigen::Matrix3d CalcNeedleTranslationStiffness(SnapshotWorkspace& workspace) const;

  /// Flange pose that puts the tip at the path's start, the needle along the path.
  static Eigen::Isometry3d CalcStartFlangePose(const NeedleConfig& needle,
                                               const SteeringPathConfig& path);

  const std::vector<PathPoint>& path() const { return path_; }
  /// Unit planned direction (entry -> target), n_traj of eq. 3.4.
  const Eigen::Vector3d& path_direction() const { return direction_; }
  /// Current positions of the path targets (m).
  std::vector<Eigen::Vector3d> CalcPathPositions() const;
  /// Current liver positions (m), 3 x #nodes.
  const Eigen::Matrix3Xd& liver_positions() const { return state_->x; }
  const FemModel& liver_model() const { return *model_; }
  /// Markers as liver material points.
  const std::vector<TetPoint>& markers() const { return markers_; }
  /// The needle pose at the end of the last step (flexible: its base frame).
  const Eigen::Isometry3d& X_WN() const { return needle_state_.X_WN_end; }
  const RigidNeedleModel& needle() const { return needle_; }
  /// The flexible needle's state, nullptr for a rigid needle.
  const BeamNeedleState* beam_needle() const { return beam_state_.get(); }
  /// The needle tip (m) and tip frame (z along the needle at the tip) at the end of the last
  /// step.
  Eigen::Vector3d CalcTipPosition() const;
  Eigen::Matrix3d CalcTipFrame() const;
  /// Liver coupling state (phase, points) after the last step.
  const TissueCouplingState& liver_coupling() const { return coupling_state_.tissues[0]; }
  bool liver_punctured() const;
  /// Where the model's tip is between its liver trajectory points after the last step
  /// (NeedleTissueCoupling::CalcTipStretch); nullopt unless it is in the liver.
  std::optional<NeedleTissueCoupling::TipStretch> CalcLiverTipStretch() const {
    return coupling_->CalcTipStretch(0, coupling_state_);
  }
  /// Current position of the liver entry point (first path point of the coupling); false
  /// before the liver is punctured.
  bool CalcLiverEntryPoint(Eigen::Vector3d* p_W) const;
  double time() const { return state_->time; }
  int64_t steps() const { return steps_; }

 private:
  // this step's bevel load on the liver or the beam's tip (the last one removed); see Step
  void ApplyBevelLoad(double bevel_angle);
  // the needle straight at the flange pose X_WF, at rest, no bevel load on it
  void ResetNeedle(const Eigen::Isometry3d& X_WF);

  InverseModelConfig config_;
  TetMesh mesh_;
  std::unique_ptr<FemModel> model_;
  std::unique_ptr<FemSolver> solver_;
  std::unique_ptr<FemState> state_;
  std::unique_ptr<FemConstraintBody> body_;
  RigidNeedleModel needle_;
  RigidNeedleState needle_state_;  // the needle (rigid) or its base frame (flexible)
  // flexible needle (config.needle_kind kFlexible), else null
  std::unique_ptr<BeamNeedleModel> beam_model_;
  std::unique_ptr<BeamNeedleState> beam_state_;
  std::unique_ptr<BeamNeedleBody> beam_body_;
  Eigen::Vector3d beam_tip_force_ = Eigen::Vector3d::Zero();   // bevel load held (N)
  Eigen::Vector3d beam_tip_torque_ = Eigen::Vector3d::Zero();  // (N m)
  // the frozen step's bodies with a beam: the liver (probes_) and the beam (tip position and
  // tip rotation increment as probes, its free-motion sensitivity)
  std::vector<SnapshotBody> snapshot_bodies_;
  Eigen::Matrix3d snapshot_R_WTip_start_ = Eigen::Matrix3d::Identity();  // beam tip at capture
  std::unique_ptr<NeedleTissueCoupling> coupling_;
  NeedleCouplingState coupling_state_;
  std::vector<TetPoint> markers_;
  std::vector<Eigen::Vector3d> marker_positions_;  // measured at the last step end (m)
  std::vector<PathPoint> path_;
  std::vector<SnapshotProbe> probes_;  // one per distinct path reference, path_probe_[i]
  std::vector<int> path_probe_;
  std::vector<std::pair<int, Eigen::Vector3d>> bevel_loads_;  // (node, force) held this step (N)
  Eigen::Vector3d direction_ = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d start_W_ = Eigen::Vector3d::Zero();  // the path's start (m)
  ConstraintSet set_;
  ConstraintSolver constraint_solver_;
  ConstraintSnapshot snapshot_;
  bool has_snapshot_ = false;
  int64_t steps_ = 0;
};

}  // namespace nsim
