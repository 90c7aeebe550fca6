#pragma once
// Needle-tissue interaction by constraints (Duriez 2009; thesis §2.1.3, §3.1), for any number
// of tissue bodies (skin, then liver), with a rigid (kinematic) or flexible (body) needle.
//
// Per tissue, a phase:
//  - kOutside: each step the tip's motion (from `contact_margin` behind the tip at the step
//    start to the tip at the step end) is intersected with the tissue's boundary surface
//    (SurfaceLocator on the start-of-step positions); a hit creates a contact.
//  - kContact: a unilateral contact n . (x_tip - x_surface) >= 0 at the hit's material point
//    (n: the current outward normal of its triangle). The puncture happens at the end of the
//    first step whose axial contact force lambda max(0, -n . z_tip) reaches puncture_force
//    (N); a contact whose force is zero and which has opened goes back to kOutside.
//  - kInside: the tissue material point where the contact was becomes the entry point; a
//    trajectory point is seeded at the tip (its barycentric coordinates in the tet holding the
//    tip, i.e. a material point, defined in the rest configuration too) each time the depth
//    (needle arc length from the entry point to the tip) has grown by point_spacing since the
//    last seed. Every point (entry, trajectory, exit) gets:
//      * two bilateral rows orthogonal to the needle, d_k . (x_tissue - x_needle(u)) = 0, at
//        the needle point u closest to the tissue point at the step start (a kinematic point
//        for the rigid needle, a point between two beam nodes for the flexible one): the
//        tissue point stays on the needle line while the needle slides through it;
//      * an axial friction row z . (x_tissue - x_needle(u)) = its start value (it measures
//        the relative axial slip over the step) with |lambda| <= mu |lambda_lateral| + f_0,
//        f_0 = friction_force_per_length * point_spacing: Coulomb friction whose normal force
//        is estimated from the point's lateral constraint force, plus a constant stiction
//        per unit length (the kAxialFriction law of the constraint set, whose normal group
//        is the point's lateral rows; constraint_solver.h). Omitted when mu = f_0 = 0.
//    Tip constraint (tip_constraint): the tissue ahead of the tip is cut, so nothing holds
//    the tip axially (the cutting resistance is not modelled), but laterally the tip follows
//    the tissue: two rows orthogonal to the tip direction tie the needle tip to the tissue
//    material point that held the tip at the step start. The tip can thus only advance along
//    its own direction: a bevel that turns the tip steers the path. Within a quarter spacing
//    of the last seeded point the rows would be nearly redundant with that point's (tip_hold):
//    with `quarter` they are skipped there, so the hold appears and disappears at once when the
//    tip crosses a quarter spacing (a loaded hold released in one step: on the default scenario
//    the registered target jumped by 1.7 mm); with `ramp` they are soft there
//    (ConstraintRow::softness = quarter spacing / distance - 1): the hold grows in proportion
//    to the tip's distance from the last point, from nothing at it to rigid at a quarter
//    spacing, and the rows are skipped only within 2 % of that (a hold of at most 2 %).
//    With `handover` the roles swap: the tip is held rigidly at every depth, and the last
//    seeded point is the one that is skipped within 2 % and softened within the quarter
//    spacing (its hold grows from nothing to rigid as the tip leaves it), so the tissue at the
//    tip, where a target is approached, is never let go when the tip's depth crosses a
//    threshold (the tissue sliding back along the needle).
//    How far the tip is past the last point, for its hold and for seeding the next point
//    (seed_distance): by default the depth grown since the seed, which also changes when the
//    tissue at the entry slides along the needle (a frictionless liver does, with the
//    breathing); with `last_point`, the tip's arc-length distance from that point's projection
//    on the needle, which follows the tissue near the tip only: consecutive points are then a
//    spacing apart in the tissue whatever the entry does.
//    lateral_compliance and tip_compliance (m/N, 0 by default) put a spring in series with
//    the lateral rows of the trajectory points and of the tip (ConstraintRow::compliance): the
//    held material point then lags the needle by that compliance times its lateral force (the
//    tissue around the needle that the mesh does not resolve; README "Where the registration
//    error comes from" has what it did to the closed loop).
//    A tip found outside the mesh within 10 % of point_spacing of the entry is just not held
//    (it is at the entry surface: just punctured, or backing out).
//  - kExited: the tip left the tissue through its far surface; an exit point is seeded where
//    the needle crosses the surface (a trajectory point), the tip is no longer constrained
//    by this tissue, and the needle may enter the next one.
// Retraction: a point that ends up ahead of the tip (by more than 10 % of point_spacing) is
// removed; removing the exit point returns to kInside, removing the entry point to kOutside
// (the tissue must then be punctured again).
//
// Step protocol (see NeedleInsertionStepper for a complete driver):
//   tissues and flexible needle: BeginStep (free motion); set.Clear(); add their bodies;
//   coupling.AddConstraints(needle view, tissue body indices, set, state);
//   ConstraintSolver::Solve(set); end the steps;
//   coupling.Update(needle view at the step end, tissue positions at the step end, solver
//                   multipliers, time, state).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "common/constraints/constraint_set.h"
#include "common/mesh/mesh_adjacency.h"
#include "common/mesh/tet_mesh.h"
#include "common/mesh/tet_point.h"
#include "common/needle/bevel_tip.h"

namespace nsim {

class BeamNeedleBody;
class RigidNeedleModel;
struct RigidNeedleState;

/// Where the tip is held laterally after a seeded point (see the file comment): from a quarter
/// spacing past it on (kQuarter, the default), ramped in over that quarter spacing (kRamp), or
/// at every depth, the seeded point's hold ramped in instead (kHandover).
enum class TipHold { kQuarter, kRamp, kHandover };
/// The YAML names of TipHold, in its order: quarter, ramp, handover.
const std::vector<std::string>& TipHoldNames();

/// How far the tip is past the last seeded point, for its hold and for the next seed (see the
/// file comment): the depth grown since the seed (kDepth: the arc length from the entry point,
/// which moves when the tissue at the entry slides along the needle), or the tip's arc-length
/// distance from that point's projection on the needle (kLastPoint: what the tissue near the
/// tip does).
enum class SeedDistance { kDepth, kLastPoint };
/// The YAML names of SeedDistance, in its order: depth, last_point.
const std::vector<std::string>& SeedDistanceNames();

/// Needle-tissue interaction parameters of one tissue body.
struct TissueCouplingConfig {
  std::string name = "tissue";  ///< for reports and messages
  /// Axial contact force at which the surface is punctured (N), > 0; skin ~1 N (REFERENCE.md).
  double puncture_force = 1.0;
  /// Coulomb coefficient of the axial friction (-), >= 0 (SOFA needle example: 0.1).
  double friction_coefficient = 0.1;
  /// Constant friction (stiction) per unit inserted length (N/m), >= 0.
  double friction_force_per_length = 0.0;
  /// Delta l_c: spacing of the trajectory points along the path (m), > 0 (SOFA needle example
  /// 1.3 cm; thesis gelatin fit 3.5 cm).
  double point_spacing = 0.013;
  /// Constrain the tip laterally to the tissue it is in (see the file comment).
  bool tip_constraint = true;
  /// How the tip's hold meets the last seeded point's (see the file comment; YAML tip_hold).
  TipHold tip_hold = TipHold::kQuarter;
  /// What the tip's distance past the last seeded point, for its hold and the next seed, is
  /// measured by (YAML seed_distance).
  SeedDistance seed_distance = SeedDistance::kDepth;
  /// Compliance of the tissue around the needle that the mesh does not resolve (m/N), >= 0:
  /// added in series to each lateral row of the trajectory points (ConstraintRow::compliance).
  /// 0: the material point is held rigidly (the default).
  double lateral_compliance = 0.0;
  /// The same for the tip's lateral rows (m/N), >= 0; 0: rigid (the default).
  double tip_compliance = 0.0;
  /// The contact search starts this far behind the tip (m), >= 0: catches a surface that moved
  /// onto the tip during the previous step.
  double contact_margin = 2e-3;

  /// Throws InputError "<prefix>.<key> must be ..., got <value>".
  void Validate(const std::string& prefix = "tissue") const;
};

/// The coupling configuration: one entry per tissue body (in the order they are passed to
/// AddConstraints), and the bevel tip.
struct NeedleCouplingConfig {
  std::vector<TissueCouplingConfig> tissues;
  BevelConfig bevel;

  /// Throws InputError naming the key ("coupling.tissues[1].point_spacing must be ...").
  void Validate() const;
};

/// The needle during one step, as the coupling sees it: a polyline of equally spaced nodes
/// from the base (node 0) to the tip (last node), at the step start and at the step end
/// (rigid: the prescribed end pose; flexible: the free motion, or the committed state after
/// the step). The parameter u in [0, n-1] names the material point between nodes floor(u) and
/// floor(u) + 1; its arc length from the base is u * segment_length.
struct NeedleView {
  Eigen::Matrix3Xd start;  ///< node positions at the step start (m), 3 x n, n >= 2
  Eigen::Matrix3Xd end;    ///< node positions at the step end (m), 3 x n
  double segment_length = 0.0;  ///< rest distance between consecutive nodes (m)
  /// Index of the needle body in the ConstraintSet (its nodes 0..n-1 are the polyline),
  /// or -1 for a kinematic (rigid) needle.
  int body = -1;
  /// Tip frame at the step end (z = needle direction at the tip).
  Eigen::Matrix3d R_WTip_end = Eigen::Matrix3d::Identity();
  double bevel_angle = 0.0;  ///< bevel roll about the tip axis (rad)

  int num_nodes() const { return static_cast<int>(start.cols()); }
};

/// Rigid needle over the step: two nodes (base, tip) at X_WN_start and X_WN_end.
NeedleView MakeNeedleView(const RigidNeedleModel& model, const RigidNeedleState& state);
/// Flexible needle registered as body `body_index` of the set: start = state.x; end = the free
/// motion while the body is in a step, the committed positions otherwise.
NeedleView MakeNeedleView(const BeamNeedleBody& needle, int body_index);

enum class TissuePhase { kOutside, kContact, kInside, kExited };
const char* ToString(TissuePhase phase);

/// A tissue material point held on the needle.
struct NeedlePathPoint {
  enum class Kind { kEntry, kTrajectory, kExit };
  Kind kind = Kind::kTrajectory;
  TetPoint point;          ///< tet and barycentric coordinates (a material point)
  std::uint64_t key = 0;   ///< persistent constraint-point key (compliance cache)
  double seed_depth = 0.0; ///< depth when it was seeded (m)
  // results of the last solve
  Eigen::Vector2d lateral_force = Eigen::Vector2d::Zero();  ///< on the tissue (N)
  double axial_force = 0.0;  ///< friction force on the tissue along the needle (N)
  bool slipping = false;     ///< the friction force is at its bound
};

/// What a tissue went through in the last step.
struct TissueCouplingReport {
  TissuePhase phase = TissuePhase::kOutside;
  bool punctured = false;    ///< phase kInside or kExited
  double puncture_time = std::numeric_limits<double>::quiet_NaN();  ///< (s)
  double depth = 0.0;        ///< needle length inside the tissue (m)
  /// The tip's arc-length distance past the last seeded point's projection on the needle (m),
  /// kInside, with seed_distance last_point (0 otherwise): what it holds the tip and seeds the
  /// next point by.
  double past_last_point = 0.0;
  /// kInside with the tip located: the tip's distance past the last seeded point as
  /// seed_distance measures it (m), and the fraction of a rigid lateral hold the tip gets from
  /// it (tip_hold: 0 free, 1 rigid, in between with ramp; 0 without the tip constraint): what
  /// the next step's tip rows and seeding use. 0 otherwise.
  double past_seed = 0.0;
  double tip_hold = 0.0;
  int num_points = 0;        ///< entry + trajectory + exit points
  double contact_force = 0.0;        ///< contact multiplier (N), kContact
  double axial_contact_force = 0.0;  ///< its component against the needle direction (N)
  double lateral_force = 0.0;   ///< sum over points of |lateral force| (N)
  double friction_force = 0.0;  ///< sum over points of the axial force on the tissue (N)
  double tip_force = 0.0;       ///< |lateral force| of the tip constraint (N)
  Eigen::Vector3d total_force = Eigen::Vector3d::Zero();  ///< sum of forces on the tissue (N)
};

/// Per-tissue coupling state. Cheap to copy (a few small vectors).
struct TissueCouplingState {
  TissuePhase phase = TissuePhase::kOutside;
  double puncture_time = std::numeric_limits<double>::quiet_NaN();
  std::vector<NeedlePathPoint> points;  ///< entry first, in seeding order
  TetPoint contact;             ///< contact material point (kContact)
  int contact_triangle = -1;    ///< its surface triangle
  std::uint64_t contact_key = 0;
  TetPoint tip;                 ///< tissue material point at the tip (kInside), tet = -1: none
  double last_seed_depth = 0.0; ///< depth of the last seeded point (m)
  TissueCouplingReport report;  ///< of the last Update
};

/// Row bookkeeping of the last AddConstraints.
struct CouplingRowTag {
  enum class Kind { kContact, kLateral, kAxial, kTip };
  Kind kind = Kind::kLateral;
  int tissue = -1;
  int point = -1;   ///< index into the tissue's points (kLateral, kAxial)
  int row = -1;     ///< first row
  Eigen::Vector3d d0 = Eigen::Vector3d::Zero(), d1 = Eigen::Vector3d::Zero();  ///< directions
};

/// The coupling's mutable state.
struct NeedleCouplingState {
  std::vector<TissueCouplingState> tissues;
  std::uint64_t next_key = 1;
  std::vector<CouplingRowTag> tags;             ///< rows of the last AddConstraints
  /// Tissue holding the tip (kInside and located) after the last Update, -1: none. The bevel
  /// load acts while this is >= 0.
  int tip_tissue = -1;
};

/// Bevel load of the coming step (from the last Update).
struct BevelTipLoad {
  bool active = false;
  Eigen::Vector3d force_on_needle = Eigen::Vector3d::Zero();   ///< at the tip (N)
  Eigen::Vector3d torque_on_needle = Eigen::Vector3d::Zero();  ///< at the tip (N m)
  int tissue = -1;     ///< tissue holding the tip
  TetPoint tip_point;  ///< the tissue material point at the tip
  /// Transverse force Q y_B (N): a rigid needle cannot take the torque, so the tissue at the
  /// tip takes -force_for_rigid (thesis §4.2: equal and opposite).
  Eigen::Vector3d force_for_rigid = Eigen::Vector3d::Zero();
};

/// Immutable coupling model: the tissue meshes (connectivity), their adjacency, configs.
class NeedleTissueCoupling {
 public:
  /// meshes[i] is tissue i's mesh (copied). Validates the config (InputError); the number of
  /// meshes must equal config.tissues.size().
  NeedleTissueCoupling(const NeedleCouplingConfig& config,
                       const std::vector<const TetMesh*>& meshes);

  /// A state with every tissue kOutside.
  NeedleCouplingState MakeState() const;

  /// Adds this step's rows to `set`. tissue_bodies[i]: index of tissue i's body in `set` (its
  /// start and free positions are used). Fills state.tags.
  void AddConstraints(const NeedleView& needle, const std::vector<int>& tissue_bodies,
                      ConstraintSet& set, NeedleCouplingState& state) const;

  /// After the solve and the commit of every body: forces per point, puncture, seeding,
  /// retraction, exit, reports. needle: the needle at the step end (its `end`); tissue_x[i]:
  /// tissue i's positions at the step end (3 x #nodes); lambda: the multipliers of the rows
  /// AddConstraints added; time: the time at the step end (s).
  void Update(const NeedleView& needle, const std::vector<const Eigen::Matrix3Xd*>& tissue_x,
              const Eigen::VectorXd& lambda, double time, NeedleCouplingState& state) const;

  /// The nodes of tissue t the needle's tip is heading for: those of the tets its axis crosses
  /// within `distance` (m) ahead of the tip (the needle as `needle.end`, its direction the tip
  /// frame's z), from the tip's tet when it is inside the tissue, else from where the axis
  /// enters the tissue's surface (none when it does not within `distance`, or the tissue is
  /// exited); tissue positions x (3 x #nodes). Unique, in the order met along the axis (the
  /// nearest tet's first). What the next steps' points will be on: for solving their
  /// compliance columns ahead (PatientScene::Prefetch).
  std::vector<int> CalcNodesAhead(int t, const NeedleView& needle, const Eigen::Matrix3Xd& x,
                                  const NeedleCouplingState& state, double distance) const;

  /// Where p (m) is in tissue t at positions x (3 x #nodes): walking from tet `hint` (any
  /// index; -1 starts at tet 0), and when the walk leaves through the boundary, the surface's
  /// signed distance, then a global search unless p is outside for sure (past a concavity p
  /// may still be inside). tet = -1: outside.
  TetPoint Locate(int t, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& p, int hint) const;

  /// Where the tip of tissue t is between its trajectory points, as distances ahead of it (m).
  struct TipStretch {
    /// How much further the tip can advance before its lateral hold engages: the rest of the
    /// free stretch past the last seeded point (tip_hold quarter, ramp: up to a quarter
    /// spacing past it); 0 when the tip is held there (handover) or the coupling has no tip
    /// constraint. Where the needle can still be moved across its tissue.
    double free_reach = 0.0;
    /// How much further until the next point is seeded.
    double next_seed = 0.0;
    /// The length of a free stretch (a quarter spacing; 0 with handover or no tip constraint).
    double free_length = 0.0;
  };
  /// The tip's stretch in tissue t after the last Update; nullopt unless the tip is inside it.
  std::optional<TipStretch> CalcTipStretch(int t, const NeedleCouplingState& state) const;

  /// The bevel load for the next step (inactive with a symmetric tip or the tip outside).
  BevelTipLoad CalcBevelTipLoad(const NeedleView& needle, const NeedleCouplingState& state) const;

  const NeedleCouplingConfig& get_config() const { return config_; }
  const BevelLoads& get_bevel_loads() const { return bevel_loads_; }
  int num_tissues() const { return static_cast<int>(tissues_.size()); }
  const TetMesh& get_mesh(int tissue) const { return tissues_[tissue].mesh; }

 private:
  struct Tissue {
    TetMesh mesh;
    MeshAdjacency adjacency;
  };
  // the walk alone (tet = -1 when it leaves through the boundary or a concavity)
  TetPoint Walk(int t, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& p, int hint) const;

  NeedleCouplingConfig config_;
  BevelLoads bevel_loads_;
  std::vector<Tissue> tissues_;
};

}  // namespace nsim
