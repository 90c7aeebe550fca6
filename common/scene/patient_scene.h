#pragma once
// The patient scene of the direct simulation (thesis §5.1, fig. 5.1): liver and skin FEM bodies,
// rigid rib boxes in unilateral contact with the liver, the diaphragm box imposing the breathing
// motion on the liver nodes it encloses (prescribed exactly), a fixed posterior anchor, fiducial
// markers and a target carried by the liver, and the needle held by the robot's flange
// (rigid or flexible, puncturing the skin and then the liver).
//
// One step (free motion, then correction; thesis §3.1, Duriez 2009):
//   1. the diaphragm nodes get x = X + d(t + h); the bevel load of the step is applied;
//   2. liver, skin (and flexible needle) free motion;
//   3. one constraint set: needle-tissue rows (common/needle) and liver-rib contact rows
//      (liver surface node vs the closest point of a rib box, n . (x - q) >= 0, for the nodes
//      within rib_contact_margin at the free motion);
//   4. ConstraintSolver (the active set, exact for bilateral + unilateral + axial friction,
//      once the needle holds tissue; PGS for the rib contacts alone), corrections committed;
//      puncture / seeding / retraction update of the coupling.
// The model (meshes, FEM models, boxes, embedded points) is immutable after construction; the
// state (FEM states, needle, coupling) is a copyable value; the solvers with their caches live
// in the scene.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <vector>

#include "common/breathing/breathing.h"
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
#include "common/scene/scene_config.h"

namespace nsim {

/// The immutable part of the scene, built once from the config and the meshes.
class PatientSceneModel {
 public:
  /// Validates `config` (InputError), places the skin mesh (X_WS), selects the diaphragm,
  /// anchor and attached skin nodes, locates the markers and the target in the liver at rest.
  /// InputError when a marker or the target is outside the liver, a rib overlaps the liver at
  /// rest, or a box selects no node.
  PatientSceneModel(const PatientSceneConfig& config, const TetMesh& liver_mesh,
                    const TetMesh& skin_mesh_in_skin_frame);

  const PatientSceneConfig& config() const { return config_; }
  const FemModel& liver() const { return *liver_; }
  const FemModel& skin() const { return *skin_; }
  const BreathingModel& breathing() const { return breathing_; }
  const NeedleTissueCoupling& coupling() const { return *coupling_; }
  /// The rigid needle model (also present with a flexible needle: same tool offset).
  const RigidNeedleModel& rigid_needle() const { return *rigid_needle_; }
  /// The beam needle model; null for a rigid needle.
  const BeamNeedleModel* beam_needle() const { return beam_needle_.get(); }
  /// Markers and target as liver material points.
  const std::vector<TetPoint>& markers() const { return markers_; }
  const TetPoint& target() const { return target_; }
  /// Liver surface nodes that are free (candidates for rib contact), ascending.
  const std::vector<int>& contact_nodes() const { return contact_nodes_; }
  /// Liver surface nodes (all), ascending.
  const std::vector<int>& liver_surface_nodes() const { return surface_nodes_; }

 private:
  PatientSceneConfig config_;
  std::unique_ptr<FemModel> liver_, skin_;
  BreathingModel breathing_;
  std::unique_ptr<NeedleTissueCoupling> coupling_;
  std::unique_ptr<RigidNeedleModel> rigid_needle_;
  std::unique_ptr<BeamNeedleModel> beam_needle_;
  std::vector<TetPoint> markers_;
  TetPoint target_;
  std::vector<int> contact_nodes_, surface_nodes_;
};

/// The mutable state: bodies, needle and coupling. Copyable.
struct PatientSceneState {
  PatientSceneState(const PatientSceneModel& model, const Eigen::Isometry3d& X_WF);

  FemState liver;
  FemState skin;
  RigidNeedleState rigid_needle;               ///< used with a rigid needle
  std::optional<BeamNeedleState> beam_needle;  ///< used with a flexible needle
  NeedleCouplingState coupling;
  int64_t step = 0;  ///< steps taken
};

/// What one scene step did.
struct SceneStepReport {
  double time = 0.0;                ///< time at the end of the step (s)
  FemStepStats liver_stats;         ///< liver free-motion solve
  int num_rows = 0;                 ///< constraint rows (needle + ribs)
  int num_rib_contacts = 0;         ///< rib contact rows
  int num_active_rib_contacts = 0;  ///< of which pushing (lambda > 0)
  ConstraintSolveReport solve;      ///< constraint resolution
  ComplianceStats compliance;       ///< the compliance columns it solved and reused
  bool bevel_active = false;        ///< the bevel load acted
  /// the liver's background refresh was kept off the CPU during the step (one CPU only,
  /// patient.liver.refactor_hold_steps; timing-independent: it depends on the steps alone)
  bool refresh_held = false;
};

/// Puncture status of one tissue.
struct TissueStatus {
  TissuePhase phase = TissuePhase::kOutside;
  bool punctured = false;
  double puncture_time = 0.0;  ///< (s), meaningful when punctured
  double depth = 0.0;          ///< needle length inside (m)
  /// the tip's distance past the last seeded point and its hold (TissueCouplingReport)
  double past_seed = 0.0;     ///< (m)
  double tip_hold = 0.0;      ///< fraction of a rigid hold (0 free, 1 rigid)
};

/// The scene: model, state and the solvers.
class PatientScene {
 public:
  /// Builds the model and a state at rest with the needle held at the flange pose X_WF.
  PatientScene(const PatientSceneConfig& config, const TetMesh& liver_mesh,
               const TetMesh& skin_mesh_in_skin_frame, const Eigen::Isometry3d& X_WF);
  ~PatientScene();
  PatientScene(const PatientScene&) = delete;  // the bodies refer to the state
  PatientScene& operator=(const PatientScene&) = delete;

  /// Advances by one time step; the flange reaches X_WF_end at the step end, the needle rolled
  /// by bevel_angle (rad) about its axis. InputError on a non-finite pose.
  SceneStepReport Step(const Eigen::Isometry3d& X_WF_end, double bevel_angle = 0.0);

  /// Work for the next steps, done between steps (off the time from a target to the state it
  /// produces): solves the liver compliance columns those steps will likely need
  /// (PatientSceneConfig::prefetch_ahead, prefetch_rib_margin) so that they reuse them, the
  /// needle's nearest first, at most kMaxPrefetchNodes new nodes a call (the others at the next
  /// calls). Changes no result, bit for bit (a column is the same whenever it is solved).
  /// Nothing without the rest compliance. Returns the number of columns solved.
  int Prefetch();
  /// New nodes a Prefetch solves at most: 18 columns, about 4-5 ms on the 2660-node liver with
  /// its factor out of the cache, a quarter of a 20 ms period (the first look into the liver
  /// asks for 20 and more).
  static constexpr int kMaxPrefetchNodes = 6;

  double time() const { return state_.liver.time; }
  const PatientSceneModel& model() const { return *model_; }
  const PatientSceneState& state() const { return state_; }

  /// Marker positions now (m), #markers.
  void CalcMarkerPositions(std::vector<Eigen::Vector3d>* p_WM) const;
  /// Target position now (m).
  Eigen::Vector3d CalcTargetPosition() const;
  /// Needle nodes from base to tip now (m), 3 x n (2 for the rigid needle).
  Eigen::Matrix3Xd CalcNeedlePolyline() const;
  Eigen::Vector3d CalcTipPosition() const;
  /// Unit needle direction at the tip now.
  Eigen::Vector3d CalcTipDirection() const;
  /// Puncture status of the skin or the liver (kSkinTissue, kLiverTissue).
  TissueStatus GetTissueStatus(int tissue) const;
  /// The skin entry point now and the outward skin normal there; false before the puncture.
  bool CalcEntryPoint(Eigen::Vector3d* p_WP, Eigen::Vector3d* n_W) const;
  /// Largest depth of a liver surface node inside a rib box now (m), 0 when none is inside.
  double CalcMaxRibPenetration() const;
  /// Diaphragm displacement d(t) imposed at the current time (m).
  Eigen::Vector3d CalcBreathingDisplacement() const;

 private:
  int AddRibContacts(ConstraintSet& set, int liver_body);
  int PrefetchUpTo(int max_new_nodes);

  std::unique_ptr<const PatientSceneModel> model_;
  PatientSceneState state_;
  std::unique_ptr<FemSolver> liver_solver_, skin_solver_;
  std::unique_ptr<FemConstraintBody> liver_body_, skin_body_;
  std::unique_ptr<BeamNeedleBody> needle_body_;
  ConstraintSolver solver_;
  ConstraintSet set_;
  std::vector<int> rib_rows_;
  // bevel loads added to the tissues last step: (tissue, node, force)
  std::vector<std::pair<std::pair<int, int>, Eigen::Vector3d>> tissue_loads_;
  Eigen::Vector3d tip_force_ = Eigen::Vector3d::Zero(), tip_torque_ = Eigen::Vector3d::Zero();
};

}  // namespace nsim
