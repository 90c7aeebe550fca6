#pragma once
// Configuration of the patient scene of the direct simulation (thesis §5.1, fig. 5.1): a liver
// (co-rotational FEM), a skin patch between two rib boxes with its edges attached to the ribs,
// unilateral liver-rib contact, a diaphragm box whose enclosed liver nodes follow the breathing
// model exactly, a posterior anchor region of fixed liver nodes, fiducial markers and a target
// embedded in the liver, the planned path, and the needle (rigid or flexible, bevel on or off).
// Plain structs with defaults (SI units, world frame W = the liver mesh frame: +x patient
// right, +y anterior, +z superior); the direct side's scenario loader fills them from YAML.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "common/breathing/breathing.h"
#include "common/fem/fem_config.h"
#include "common/needle/beam_needle.h"
#include "common/needle/needle_tissue.h"
#include "common/needle/rigid_needle.h"
#include "common/mesh/oriented_box.h"

namespace nsim {

/// Index of the skin and the liver among the needle coupling's tissues.
inline constexpr int kSkinTissue = 0;
inline constexpr int kLiverTissue = 1;

/// The skin patch: material, placement and attachment to the ribs.
struct SkinConfig {
  /// Material, damping and solver of the skin (time step and gravity come from the scene).
  /// Default E 500 kPa (in-vivo skin is 0.1-1 MPa), direct solver (the patch is small).
  FemConfig fem = [] {
    FemConfig c;
    c.young_modulus = 5e5;
    c.poisson_ratio = 0.45;
    c.density = 1100.0;
    c.rayleigh_mass = 0.1;
    c.rayleigh_stiffness = 0.01;
    c.linear_solver = FemLinearSolver::kDirect;
    return c;
  }();
  /// Pose of the skin mesh frame S in world: the mesh's coordinates are p_S (m).
  Eigen::Isometry3d X_WS = Eigen::Isometry3d::Identity();
  /// Skin nodes within this distance of a rib box are attached to it (fixed) (m), >= 0.
  double attach_distance = 0.004;

  /// Throws InputError "patient.skin.<key> ...".
  void Validate() const;
};

/// Which needle model holds the tissue.
enum class NeedleKind { kRigid, kFlexible };

/// The needle and its coupling with the two tissues.
struct SceneNeedleConfig {
  NeedleKind kind = NeedleKind::kRigid;
  /// Geometry of the rigid needle (thesis §5.2: 13 cm, radius 0.723 mm, 200 GPa).
  NeedleConfig rigid;
  /// The flexible needle (thesis §5.3: 20 cm, radius 0.6 mm, E 5 GPa, beam elements).
  BeamNeedleConfig flexible;
  /// Coupling: tissues[0] is the skin, tissues[1] the liver; and the bevel tip.
  NeedleCouplingConfig coupling = [] {
    NeedleCouplingConfig c;
    TissueCouplingConfig skin;
    skin.name = "skin";
    skin.puncture_force = 1.0;
    TissueCouplingConfig liver;
    liver.name = "liver";
    liver.puncture_force = 0.3;
    c.tissues = {skin, liver};
    return c;
  }();

  /// The geometry of the needle in use (rigid or flexible).
  const NeedleConfig& geometry() const {
    return kind == NeedleKind::kRigid ? rigid : flexible.needle;
  }

  /// Throws InputError "needle.<key> ...".
  void Validate() const;
};

/// Everything the patient scene is made of, except the meshes (given separately: libraries take
/// config structs, the loader reads the files).
struct PatientSceneConfig {
  double time_step = 0.02;  ///< h (s) of every body, > 0
  /// Gravity (m/s^2). Zero by default: the organs around the liver (not modelled) carry it.
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();

  /// Liver material, damping and solver (thesis §5.1: E 5.5 kPa, nu 0.45; density 1060).
  FemConfig liver = [] {
    FemConfig c;
    c.rayleigh_mass = 0.1;
    c.rayleigh_stiffness = 0.01;
    return c;
  }();
  /// Compliance of the liver in the constraint solve (YAML patient.constraint_compliance):
  /// true = rest (FemInverse::kRestFactor: h^2 A_0^-1 from the liver solver's construction-time
  /// factor; constant, so the columns of persistent points are solved once), false =
  /// last_factor (FemInverse::kReferenceFactor: the liver's last factorization; the cached
  /// columns are recomputed whenever the factor is refreshed). See SelectConstraintCompliance
  /// in common/fem/fem_solver.h.
  bool liver_rest_compliance = true;
  SkinConfig skin;

  /// Rigid rib boxes in contact with the liver (unilateral, frictionless).
  std::vector<OrientedBox> ribs;
  /// Liver surface nodes closer than this to a rib box (at the free motion) get a contact row
  /// (m), >= 0.
  double rib_contact_margin = 0.005;
  /// Compliance columns solved between steps (PatientScene::Prefetch; with the rest compliance
  /// only, the one constant between steps), so that the steps that need them find them: the
  /// liver nodes of the tets the needle's axis crosses within prefetch_ahead (m) of its tip,
  /// and the liver surface nodes within prefetch_rib_margin (m) of a rib box (YAML
  /// patient.prefetch_ahead, patient.prefetch_rib_margin; 0 turns either off). Results do not
  /// depend on them, only where the time goes.
  double prefetch_ahead = 0.004;
  double prefetch_rib_margin = 0.010;
  /// Liver nodes inside this box follow the breathing motion exactly: x = X + d(t).
  OrientedBox diaphragm;
  /// Liver nodes inside any of these boxes are fixed (posterior attachment, no drift).
  std::vector<OrientedBox> anchors;
  /// The breathing motion d(t) imposed on the diaphragm nodes.
  BreathingConfig breathing;

  /// Rest positions of the fiducial markers in the liver (m), >= 1, each inside the liver.
  std::vector<Eigen::Vector3d> markers_W;
  /// Rest position of the target (tumour) in the liver (m).
  Eigen::Vector3d target_W = Eigen::Vector3d::Zero();
  /// Planned skin entry point (m): the needle is inserted along entry -> target.
  Eigen::Vector3d entry_W = Eigen::Vector3d(0.0, 0.1, 0.0);

  SceneNeedleConfig needle;

  /// Checks every field (also the nested configs) and throws InputError naming the key with
  /// the scenario's names: "patient.liver.young_modulus must be > 0 (Pa), got -3".
  void Validate() const;
};

/// Upper bounds of a tissue's material in a scenario (SI units): InputError
/// "<prefix>.young_modulus must be <= 1e+12 (Pa), got ...".
void CheckTissueBounds(const FemConfig& fem, const std::string& prefix);

}  // namespace nsim
