#include "common/scene/scene_config.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {
namespace {

// runs a nested Validate() and renames its key prefix ("fem." -> "patient.liver.")
template <typename Fn>
void Renamed(Fn&& validate, const std::string& from, const std::string& to) {
  try {
    validate();
  } catch (const InputError& e) {
    std::string what = e.what();
    if (what.compare(0, from.size(), from) == 0) what = to + what.substr(from.size());
    throw InputError(what);
  }
}

// a point of the scene: world frame = the liver's frame, origin at its centre; a patient is
// under 2 m long, so 10 m from the origin is outside any scene
constexpr double kMaxSceneDistance_m = 10.0;

void CheckFinite(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) throw InputError(Str(key, " must be finite (m), got ", v.transpose()));
  CheckNormAtMost(v, kMaxSceneDistance_m, key, "m");
}

}  // namespace

void CheckTissueBounds(const FemConfig& fem, const std::string& prefix) {
  // FemConfig itself is unit-free (the tests scale it to mm); a scenario is in SI units, where
  // no tissue is stiffer than diamond (1.2e12 Pa; soft tissue is 1e3..1e5), denser than osmium
  // (2.3e4 kg/m^3) or damped beyond 1e3 1/s or 10 s (either freezes the body)
  CheckAtMost(fem.young_modulus, 1e12, prefix + ".young_modulus", "Pa");
  CheckAtMost(fem.density, 1e5, prefix + ".density", "kg/m^3");
  CheckAtMost(fem.rayleigh_mass, 1e3, prefix + ".rayleigh_mass", "1/s");
  CheckAtMost(fem.rayleigh_stiffness, 10.0, prefix + ".rayleigh_stiffness", "s");
}

void SkinConfig::Validate() const {
  Renamed([&] { fem.Validate(); }, "fem.", "patient.skin.");
  CheckTissueBounds(fem, "patient.skin");
  if (!X_WS.matrix().allFinite()) throw InputError("patient.skin.pose must be finite");
  if (!(attach_distance >= 0))
    throw InputError(Str("patient.skin.attach_distance must be >= 0 (m), got ", attach_distance));
  // the skin patch is centimetres from the ribs: 10 cm would attach all of it
  CheckAtMost(attach_distance, 0.1, "patient.skin.attach_distance", "m");
  CheckNormAtMost(X_WS.translation(), kMaxSceneDistance_m, "patient.skin.pose.position", "m");
}

void SceneNeedleConfig::Validate() const {
  if (kind == NeedleKind::kRigid) {
    rigid.Validate("needle");
  } else {
    flexible.Validate();
  }
  if (coupling.tissues.size() != 2)
    throw InputError(
        Str("needle coupling needs 2 tissues (skin, liver), got ", coupling.tissues.size()));
  coupling.tissues[0].Validate("needle.skin");
  coupling.tissues[1].Validate("needle.liver");
  coupling.bevel.Validate("needle.bevel");
}

void PatientSceneConfig::Validate() const {
  if (!(time_step > 0) || !std::isfinite(time_step))
    throw InputError(Str("patient.time_step must be > 0 (s), got ", time_step));
  if (!gravity.allFinite())
    throw InputError(Str("patient.gravity must be finite (m/s^2), got ", gravity.transpose()));
  // a dynamic run: below 0.1 ms per step a second of breathing takes over 10^4 steps of the
  // 2656-node liver (~10 ms each), and 1e-9 s would need 2e8 steps for 0.2 s; above 0.1 s the
  // breathing (4 s period) is sampled too coarsely and the needle moves 1 mm per step at
  // 1 cm/s. The run's step count is bounded by the loader (run.duration / time_step).
  CheckRange(time_step, 1e-4, 0.1, "patient.time_step", "s");
  // 10 g: more than a patient on a table (or a bench test) ever sees
  CheckNormAtMost(gravity, 100.0, "patient.gravity", "m/s^2");
  Renamed([&] { liver.Validate(); }, "fem.", "patient.liver.");
  CheckTissueBounds(liver, "patient.liver");
  skin.Validate();
  if (ribs.empty()) throw InputError("patient.ribs must list at least one rib box");
  for (size_t i = 0; i < ribs.size(); ++i) ribs[i].Validate(Str("patient.ribs[", i, "]"));
  if (!(rib_contact_margin >= 0))
    throw InputError(Str("patient.rib_contact_margin must be >= 0 (m), got ", rib_contact_margin));
  // ribs touch the liver: a margin of 10 cm would put the whole organ in contact
  CheckAtMost(rib_contact_margin, 0.1, "patient.rib_contact_margin", "m");
  for (const auto& [value, name] : {std::pair{prefetch_ahead, "patient.prefetch_ahead"},
                                    std::pair{prefetch_rib_margin, "patient.prefetch_rib_margin"}}) {
    if (!(value >= 0)) throw InputError(Str(name, " must be >= 0 (m), got ", value));
    CheckAtMost(value, 0.1, name, "m");
  }
  diaphragm.Validate("patient.diaphragm");
  for (size_t i = 0; i < anchors.size(); ++i) anchors[i].Validate(Str("patient.anchors[", i, "]"));
  breathing.Validate();
  if (markers_W.empty()) throw InputError("patient.markers must list at least one marker");
  if (markers_W.size() > 64)
    throw InputError(Str("patient.markers: at most 64 markers, got ", markers_W.size()));
  for (size_t i = 0; i < markers_W.size(); ++i)
    CheckFinite(markers_W[i], Str("patient.markers[", i, "]"));
  CheckFinite(target_W, "patient.target");
  CheckFinite(entry_W, "patient.entry");
  if (!((target_W - entry_W).norm() > 1e-3))
    throw InputError("patient.entry and patient.target must be at least 1 mm apart");
  needle.Validate();
}

}  // namespace nsim
